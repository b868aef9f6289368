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
/// non-finite result, every likelihood zero) is left exactly as it was, with its status. Its step,
/// gating and NIS calls are TrackBankCalls' (track_bank_calls.hpp); nothing is allocated by them.

#include <Eigen/Core>
#include <cstddef>
#include <span>
#include <vector>

#include "imm/estimation/gaussian_state.hpp"
#include "imm/estimation/imm_estimator.hpp"
#include "imm/estimation/step_status.hpp"
#include "imm/filters/plain_imm.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/track_bank_calls.hpp"

namespace imm {

/// N tracks of one plain IMM whose mixing space has NX states (see the file comment).
template <int NX>
class PlainImmTrackBank : public TrackBankCalls {
 public:
  /// The state dimension (the spec's mixing dimension).
  static constexpr int kDim = NX;

  /// Room for `capacity` tracks of the IMM of `spec`. Throws InvalidParameter naming the field
  /// for an invalid spec, "capacity" out of [1, 2²⁶], or "modes" when the spec's mixing
  /// dimension is not NX.
  PlainImmTrackBank(const PlainImmSpec& spec, std::size_t capacity);

  /// The number of IMM modes.
  [[nodiscard]] int mode_count() const { return tracks_.front().mode_count(); }

  /// Starts (or restarts) track `track` from `state` (ImmEstimator::initialize). Throws
  /// std::out_of_range for a track ≥ capacity(), InvalidParameter("initial_state" /
  /// "initial_covariance") for a start the one-track filter refuses (require_initial_state).
  void initialize(std::size_t track, const GaussianState<NX>& state);

  /// Makes the following cycles of every track span `interval` s (ImmEstimator::set_interval: F, Q
  /// and the mode transitions of the interval; one sample period: the spec's own numbers). False,
  /// and nothing changed, for a spec with a noise schedule or an interval outside
  /// limits::kSamplePeriod. Nothing is allocated.
  bool set_interval(double interval);

  /// The combined estimate of a track.
  [[nodiscard]] GaussianState<NX> estimate(std::size_t track) const;
  /// μ_j of a track (linear; may hold exact zeros after underflow).
  [[nodiscard]] ModeVector mode_probabilities(std::size_t track) const;
  /// log μ_j of a track.
  [[nodiscard]] ModeVector log_mode_probabilities(std::size_t track) const;

 private:
  // TrackBankCalls' step: each track's ImmEstimator::step, its NIS that of last_step_nis.
  void step_lanes(const LaneStep& call) override;
  // TrackBankCalls' gating matrix: each track predicted (ImmEstimator::predict), each plot scored
  // by its candidate_distance and candidate_log_likelihood; a spec with a noise schedule scores a
  // pair by a trial update and gates on the prediction without the plot.
  void score_lanes(const LaneScore& call) override;
  std::vector<ImmEstimator<NX, 2>> tracks_;
  double sample_period_ = 0.0;
};

extern template class IMM_RUNTIME_EXPORT PlainImmTrackBank<4>;
extern template class IMM_RUNTIME_EXPORT PlainImmTrackBank<5>;
extern template class IMM_RUNTIME_EXPORT PlainImmTrackBank<6>;
extern template class IMM_RUNTIME_EXPORT PlainImmTrackBank<7>;

}  // namespace imm
