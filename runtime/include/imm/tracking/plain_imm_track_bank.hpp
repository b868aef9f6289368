// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Many independent tracks of any plain IMM — CV, CA, Singer and coordinated-turn (EKF) modes,
/// Cartesian or polar plots — stepped by one call, for the specs TrackBank's vectorized
/// constant-velocity kernel does not cover (track_bank.hpp). NX is the spec's mixing dimension
/// (PlainImmSpec::mixing_dimension(): 4 to 7).
///
/// Each track is the one-track IMM itself (build_plain_imm, ImmEstimator): the bank adds no second
/// copy of the step, so a track of the bank equals a one-track filter of the same spec fed the
/// same plots to the bit, and a track whose step fails (an unusable plot, a singular S, a
/// non-finite result, every likelihood zero) is left exactly as it was, with its status. Nothing
/// is allocated by step().

#include <Eigen/Core>
#include <cstddef>
#include <span>
#include <vector>

#include "imm/estimation/gaussian_state.hpp"
#include "imm/estimation/imm_estimator.hpp"
#include "imm/estimation/step_status.hpp"
#include "imm/filters/plain_imm.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// N tracks of one plain IMM whose mixing space has NX states (see the file comment).
template <int NX>
class PlainImmTrackBank {
 public:
  /// The state dimension (the spec's mixing dimension).
  static constexpr int kDim = NX;

  /// Room for `capacity` tracks of the IMM of `spec`. Throws InvalidParameter naming the field
  /// for an invalid spec, "capacity" out of [1, 2²⁶], or "modes" when the spec's mixing
  /// dimension is not NX.
  PlainImmTrackBank(const PlainImmSpec& spec, std::size_t capacity);

  /// The number of tracks it holds.
  [[nodiscard]] std::size_t capacity() const { return tracks_.size(); }
  /// The number of IMM modes.
  [[nodiscard]] int mode_count() const { return tracks_.front().mode_count(); }

  /// Starts (or restarts) track `track` from `state` (ImmEstimator::initialize). Throws
  /// std::out_of_range for a track ≥ capacity(), InvalidParameter("state") for a mean or
  /// covariance with NaN or ±Inf or a negative variance.
  void initialize(std::size_t track, const GaussianState<NX>& state);

  /// One IMM cycle of tracks 0 … plots.size() − 1, track t with plots[t] (in the spec's plot
  /// coordinates); status[t] receives its outcome. Throws std::invalid_argument when the spans
  /// differ in size or exceed capacity(), std::logic_error when a stepped track was never
  /// initialized.
  void step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status);
  /// step(), stating each stepped track's normalized innovation squared (TrackBank::step with
  /// `nis`): the NIS last_step_nis gives its one-track filter after the same step, NaN where
  /// status[t] is not kOk or none. Throws as step(), and std::invalid_argument when `nis` differs
  /// in size from `plots`.
  void step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status,
            std::span<double> nis);

  /// The gating matrix of tracks 0 … out.rows() − 1 against `plots` without changing a track's
  /// estimate (TrackBank::candidate_log_likelihoods): out(t, q) = the track's
  /// ImmEstimator::candidate_log_likelihood of plot q, or −∞ where its candidate_distance exceeds
  /// `gate`; NaN for an unusable plot or a track whose prediction failed. A track is predicted
  /// (ImmEstimator::predict) and each plot scored; the next step() is the full cycle, with the
  /// same numbers as without this call. A spec with a noise schedule scores each pair by a trial
  /// update and gates on the prediction without the plot (ImmEstimator::predict). Throws as
  /// TrackBank's does. Nothing is allocated.
  void candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots, double gate,
                                 Eigen::Ref<Eigen::MatrixXd> out);
  /// The same with a gate per track, gate × gate_scale[t] (TrackBank's overload).
  void candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots, double gate,
                                 std::span<const double> gate_scale,
                                 Eigen::Ref<Eigen::MatrixXd> out);

  /// Makes the following cycles of every track span `interval` s (ImmEstimator::set_interval: F, Q
  /// and the mode transitions of the interval; one sample period: the spec's own numbers). False,
  /// and nothing changed, for a spec with a noise schedule or an interval outside
  /// limits::kSamplePeriod. Nothing is allocated.
  bool set_interval(double interval);

  /// Whether track `track` has been initialized.
  [[nodiscard]] bool initialized(std::size_t track) const;
  /// The combined estimate of a track.
  [[nodiscard]] GaussianState<NX> estimate(std::size_t track) const;
  /// μ_j of a track (linear; may hold exact zeros after underflow).
  [[nodiscard]] ModeVector mode_probabilities(std::size_t track) const;
  /// log μ_j of a track.
  [[nodiscard]] ModeVector log_mode_probabilities(std::size_t track) const;

 private:
  [[nodiscard]] std::size_t checked(std::size_t track) const;
  // The gating matrix once the arguments are checked; gate_scale: a factor per track, or null.
  void score(std::span<const Eigen::Vector2d> plots, double gate, const double* gate_scale,
             Eigen::Ref<Eigen::MatrixXd> out);
  std::vector<ImmEstimator<NX, 2>> tracks_;
  std::vector<unsigned char> initialized_;
  double sample_period_ = 0.0;
};

extern template class IMM_RUNTIME_EXPORT PlainImmTrackBank<4>;
extern template class IMM_RUNTIME_EXPORT PlainImmTrackBank<5>;
extern template class IMM_RUNTIME_EXPORT PlainImmTrackBank<6>;
extern template class IMM_RUNTIME_EXPORT PlainImmTrackBank<7>;

}  // namespace imm
