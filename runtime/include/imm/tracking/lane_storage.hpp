// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The storage the banks of the learned kinds share: a structure of arrays of state slots, one
/// lane per track (or per track axis), the lanes padded to whole blocks so that a block's kernel
/// reads and writes whole vectors, and which tracks have been started. GaFuzzyTrackBank,
/// InputEstimatorTrackBank and FcmImmTrackBank derive from it, WimmTrackBank and FimmTrackBank
/// through TwoModeLaneStorage (two_mode_lane_storage.hpp); what a slot holds is each bank's own.
/// So do the calls every such bank answers — a step, a step that states each track's NIS, and the
/// gating matrix with one gate or a gate per track — checked here once, then run by the bank's
/// step_lanes and score_lanes.

#include <Eigen/Core>
#include <cstddef>
#include <span>
#include <string_view>
#include <vector>

#include "imm/core/aligned_allocator.hpp"
#include "imm/estimation/step_status.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// Tracks as lanes of a structure of arrays (see the file comment).
class IMM_RUNTIME_EXPORT LaneStorage {
 public:
  /// The number of tracks it holds.
  [[nodiscard]] std::size_t capacity() const { return initialized_.size(); }

  /// Whether track `track` has been initialized. Throws std::out_of_range for a track ≥
  /// capacity().
  [[nodiscard]] bool initialized(std::size_t track) const;

  /// The calls below are TrackBank's (imm/tracking/track_bank.hpp), with each bank's own step
  /// and candidate questions (its class comment and step_lanes / score_lanes); they check their
  /// arguments as TrackBank does, naming the bank, and allocate nothing.
  ///
  /// One cycle of the tracks with plots: track t with plots[t], status[t] its outcome.
  void step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status);
  /// A cycle stating each stepped track's NIS, its one-track filter's last_step_nis (ν and S of
  /// the update, over the modes collapsed with the predicted c_j), as closely as the bank follows
  /// the filter; NaN for a track whose step failed. A covariance calibration follows it.
  void step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status,
            std::span<double> nis);
  /// The gating matrix: out(t, q) the log-likelihood of plot q under track t's prediction, −∞ past
  /// `gate`, NaN for a plot that cannot be scored; no track changes. std::logic_error from a bank
  /// that answers no gating question (a wIMM that fuses the azimuth or converts the plot).
  void candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots, double gate,
                                 Eigen::Ref<Eigen::MatrixXd> out);
  /// The gating matrix with a gate per track, gate × gate_scale[t] (CalibratedTrackBank).
  void candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots, double gate,
                                 std::span<const double> gate_scale,
                                 Eigen::Ref<Eigen::MatrixXd> out);

  /// A bank is destroyed through its own type or this one.
  virtual ~LaneStorage() = default;

 protected:
  /// A bank named `name` (in the messages of its refusals).
  explicit LaneStorage(std::string_view name) : name_(name) {}
  /// A copy of the storage (a bank's copy).
  LaneStorage(const LaneStorage&) = default;
  /// The storage moved (a bank's move).
  LaneStorage(LaneStorage&&) = default;
  /// A copy of the storage (a bank's copy).
  LaneStorage& operator=(const LaneStorage&) = default;
  /// The storage moved (a bank's move).
  LaneStorage& operator=(LaneStorage&&) = default;

  /// The bank's step once the arguments are checked: `nis` null, or plots.size() entries.
  virtual void step_lanes(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status,
                          double* nis) = 0;
  /// The bank's gating matrix once the arguments are checked: `gate_scale` null (every factor
  /// 1), or out.rows() factors.
  virtual void score_lanes(std::span<const Eigen::Vector2d> plots, double gate,
                           const double* gate_scale, Eigen::Ref<Eigen::MatrixXd> out) = 0;

  /// Room for `capacity` tracks of `lanes_per_track` lanes each, `slots` slots of a lane, the
  /// lanes rounded up to whole blocks of `block` (and to stride()): every slot 0, no track
  /// initialized. Throws
  /// InvalidParameter("capacity") for a capacity outside [1, 2^26].
  void allocate(std::size_t capacity, int lanes_per_track, int block, std::size_t slots);

  /// Slot `index`'s first lane; the slots are stride() lanes apart.
  [[nodiscard]] double* slot(int index) { return state_.data() + index * stride_; }
  /// Slot `index`'s first lane.
  [[nodiscard]] const double* slot(int index) const { return state_.data() + index * stride_; }
  /// Lanes per slot: the tracks' lanes rounded up to whole blocks, and to an odd number of
  /// cache lines.
  [[nodiscard]] std::ptrdiff_t stride() const { return stride_; }

  /// `track` as an index, or std::out_of_range when it is not below capacity().
  [[nodiscard]] std::ptrdiff_t checked(std::size_t track) const;
  /// Marks track `track` (an index checked() gave) as initialized.
  void mark_initialized(std::ptrdiff_t track) { initialized_[static_cast<std::size_t>(track)] = 1; }

  /// Before the step of bank `name` over `plots` tracks with `statuses` statuses:
  /// std::invalid_argument when the counts differ or exceed capacity(), std::logic_error naming
  /// the first stepped track never initialized.
  void check_step(std::string_view name, std::size_t plots, std::size_t statuses) const;
  /// Before the gating matrix of bank `name` of `plots` plots into a rows × cols matrix:
  /// std::invalid_argument when cols differs from plots or rows exceeds capacity(),
  /// InvalidParameter("gate") for a gate that is NaN or not positive, std::logic_error naming the
  /// first track never initialized.
  void check_candidates(std::string_view name, std::size_t plots, double gate, std::ptrdiff_t rows,
                        std::ptrdiff_t cols) const;

 private:
  std::string_view name_;
  std::ptrdiff_t stride_ = 0;
  std::vector<double, AlignedAllocator<double>> state_;  // slots × stride, slot 0 on a line
  std::vector<unsigned char> initialized_;
};

}  // namespace imm
