// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The calls every track bank answers — a step, a step that states each track's NIS, and the
/// gating matrix with one gate or a gate per track — and which of its tracks have been started:
/// written once here, each checking its arguments (naming the bank) before it runs the bank's own
/// step_lanes or score_lanes. TrackBank, PlainImmTrackBank and, through LaneStorage
/// (lane_storage.hpp), the banks of the learned kinds derive from it. One virtual call per bank
/// call, none per track; nothing is allocated.

#include <Eigen/Core>
#include <cstddef>
#include <span>
#include <string_view>
#include <vector>

#include "imm/estimation/step_status.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// What every track bank answers (see the file comment).
class IMM_RUNTIME_EXPORT TrackBankCalls {
 public:
  /// The number of tracks it holds.
  [[nodiscard]] std::size_t capacity() const { return initialized_.size(); }

  /// Whether track `track` has been initialized. Throws std::out_of_range for a track ≥
  /// capacity().
  [[nodiscard]] bool initialized(std::size_t track) const;

  /// One cycle of tracks 0 … plots.size() − 1, track t with plots[t] (in the plot coordinates of
  /// the bank's model); status[t] receives its outcome (a track whose status is not kOk is left
  /// exactly as it was). Tracks from plots.size() on are not touched. Throws
  /// std::invalid_argument when the spans differ in size or exceed capacity(), std::logic_error
  /// naming the first stepped track never initialized.
  void step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status);

  /// step(), stating each stepped track's normalized innovation squared νᵀ S⁻¹ ν (ν and S of the
  /// update, over the modes collapsed with the predicted c_j): what last_step_nis gives the
  /// track's one-track filter after the same step, as closely as the bank follows that filter
  /// (each bank's class comment); NaN where status[t] is not kOk or S is not positive definite. A
  /// covariance calibration follows it (CalibratedTrackBank). Throws as step(), and
  /// std::invalid_argument when `nis` differs in size from `plots`.
  void step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status,
            std::span<double> nis);

  /// The gating question for many tracks and plots in one call, without changing any track:
  /// out(t, q) = log p(z_q | Z_t), the log-likelihood of candidate plot q under track t's
  /// prediction (ImmEstimator::candidate_log_likelihood), for tracks 0 … out.rows() − 1, or −∞
  /// where the plot's squared distance to the collapsed prediction
  /// (ImmEstimator::candidate_distance) is above `gate` (e.g. chi_square_quantile(0.99, 2); +∞
  /// scores every pair). NaN for an unusable plot or a track whose prediction has no positive
  /// definite S. Then step() with the plots chosen gives the same numbers as without this call.
  /// Throws std::invalid_argument when out.cols() differs from plots.size() or out.rows() exceeds
  /// capacity(), InvalidParameter("gate") for a gate that is NaN or not positive,
  /// std::logic_error for a track never initialized or a bank that answers no gating question (a
  /// wIMM that fuses the azimuth or converts the plot).
  void candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots, double gate,
                                 Eigen::Ref<Eigen::MatrixXd> out);

  /// The same with a gate per track: track t's pairs are outside where their distance is above
  /// gate × gate_scale[t] (a calibrated S scaled by gate_scale[t]: CalibratedTrackBank). Throws
  /// as above, and InvalidParameter("gate_scale…") unless `gate_scale` holds out.rows() factors,
  /// each finite and positive.
  void candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots, double gate,
                                 std::span<const double> gate_scale,
                                 Eigen::Ref<Eigen::MatrixXd> out);

  /// A bank is destroyed through its own type or this one.
  virtual ~TrackBankCalls() = default;

 protected:
  /// A bank named `name` (in the messages of its refusals), holding no track yet.
  explicit TrackBankCalls(std::string_view name) : name_(name) {}
  /// A copy of the calls' state (a bank's copy).
  TrackBankCalls(const TrackBankCalls&) = default;
  /// The calls' state moved (a bank's move).
  TrackBankCalls(TrackBankCalls&&) = default;
  /// A copy of the calls' state (a bank's copy).
  TrackBankCalls& operator=(const TrackBankCalls&) = default;
  /// The calls' state moved (a bank's move).
  TrackBankCalls& operator=(TrackBankCalls&&) = default;

  /// A step once its arguments are checked: `nis` null, or plots.size() entries.
  struct LaneStep {
    std::span<const Eigen::Vector2d> plots;  ///< a plot per stepped track
    std::span<StepStatus> status;            ///< a status per stepped track, to write
    double* nis;                             ///< null, or an NIS per stepped track to write
  };
  /// A gating matrix once its arguments are checked: `gate_scale` null (every factor 1), or
  /// out.rows() factors.
  struct LaneScore {
    std::span<const Eigen::Vector2d> plots;   ///< the candidate plots, a column each
    double gate;                              ///< the gate on the squared distance
    const double* gate_scale;                 ///< null, or a factor of the gate per track
    mutable Eigen::Ref<Eigen::MatrixXd> out;  ///< a view: what it points at is the answer
    /// Track `track`'s gate: gate × gate_scale[track], or gate where gate_scale is null.
    [[nodiscard]] double gate_of(std::size_t track) const {
      return gate_scale == nullptr ? gate : gate * gate_scale[track];
    }
  };
  /// The bank's step.
  virtual void step_lanes(const LaneStep& call) = 0;
  /// The bank's gating matrix.
  virtual void score_lanes(const LaneScore& call) = 0;

  /// Room for `capacity` tracks, none initialized. Throws InvalidParameter("capacity") for a
  /// capacity outside [1, 2^26].
  void hold_tracks(std::size_t capacity);
  /// `track` as an index, or std::out_of_range when it is not below capacity().
  [[nodiscard]] std::ptrdiff_t checked(std::size_t track) const;
  /// Marks track `track` (an index checked() gave) as initialized.
  void mark_initialized(std::ptrdiff_t track) { initialized_[static_cast<std::size_t>(track)] = 1; }

 private:
  std::string_view name_;
  std::vector<unsigned char> initialized_;
};

}  // namespace imm
