// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Many independent tracks of one weighted IMM (wimm.hpp), stepped by one call: the multi-track
/// form of WimmFilter, as TrackBank is of the plain IMM.
///
/// Layout: every track is a lane (its two modes, the CV's 4 states and the Singer's 6, with their
/// covariances' upper triangles, and log μ), stored structure of arrays and stepped 8 at a time.
/// A step runs in three phases per block:
///   1. vector loops: the predicted mode probabilities, the mixing in the 6-state space and both
///      modes' predictions, their predicted ranges and azimuths and the fusion's θ̄;
///   2. one scalar loop over the lanes: whether to fuse, the fused azimuth and the wrapped
///      residuals (and, for the converted update, the plot's conversion); it leaves every mode's
///      linearization — H at the position, R and the innovation — to
///   3. vector loops: both modes' Joseph-form updates, their likelihoods and the posterior μ.
/// The vector loops have no branches and no calls, and the compiler vectorizes them: AVX-512 or
/// AVX2 where the CPU has it, chosen at run time, without fused multiply-add, so a track's result
/// does not depend on the instruction set, on its position or on the number of tracks.
///
/// Every fusion variant and both measurement updates run as in WimmFilter::step. The differences
/// to the one-track filter are rounding only: exp, log and atan2 are lane_exp, lane_log and
/// lane_atan2 (lane_math.hpp, within 2 ulp of libm's), a range is √(x² + y²) rather than hypot,
/// the fusion's sin θ_j and cos θ_j are x_j / r_j and y_j / r_j, and the products sum only H's
/// non-zero entries. A track whose plot is unusable,
/// or whose step fails in either mode, is left exactly as it was, with the status of the first mode
/// that failed (CV, then Singer), as the one-track filter reports it.
///
/// Every transition probability must be positive: c_j then never vanishes, so no mode is ever
/// unreachable. Nothing is allocated after construction.

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <span>
#include <vector>

#include "imm/estimation/gaussian_state.hpp"
#include "imm/estimation/step_status.hpp"
#include "imm/filters/wimm.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/two_mode_lane_storage.hpp"

namespace imm {

/// N tracks of one weighted IMM with polar plots, stepped together (see the file comment).
class IMM_RUNTIME_EXPORT WimmTrackBank : public TwoModeLaneStorage {
 public:
  /// Tracks per block of the layout.
  static constexpr int kBlock = 8;

  /// Room for `capacity` tracks of `spec`. Throws InvalidParameter naming the field for an invalid
  /// spec (WimmSpec::validate), a transition probability that is not positive ("transition") or a
  /// capacity outside [1, 2^26].
  WimmTrackBank(const WimmSpec& spec, std::size_t capacity);

  /// Starts (or restarts) track `track` from `state` ([x, vx, ax, y, vy, ay]): both modes take
  /// their components of it, μ its initial value (WimmFilter::initialize). Throws
  /// std::out_of_range for a track ≥ capacity(), InvalidParameter("initial_state" /
  /// "initial_covariance") for a start the one-track filter refuses (require_initial_state).
  void initialize(std::size_t track, const GaussianState<6>& state);

  // estimate(track) is [x, vx, ax, y, vy, ay] (WimmFilter::estimate), mode_probabilities(track)
  // μ = (CV, Singer): TwoModeLaneStorage's.

  /// Whether the track's last successful step fused the azimuth (WimmFilter::fused).
  [[nodiscard]] bool fused(std::size_t track) const;

  // step(), step() with the NIS and candidate_log_likelihoods() are TrackBankCalls'.

 private:
  struct Constants;
  // One scan of the tracks (polar plots); with `nis`, the modes' ν_j and S_j of the update,
  // rewritten into the plot's where the track fused the azimuth (WimmFilter::innovation),
  // collapsed with the predicted c_j: the one-track wIMM's last_step_nis to rounding, in every
  // configuration.
  void step_lanes(const LaneStep& call) override;
  // For the split cycle's configuration (no fusion, the extended update: the nIMM): log Σ_j c_j
  // N(ν_j; 0, S_j) of the candidate under the prediction, gated by its squared distance to the
  // collapsed predicted plot — the one-track WimmFilter's candidate questions after predict(), to
  // rounding. std::logic_error for a wIMM that fuses the azimuth or converts the plot (it has no
  // split cycle).
  void score_lanes(const LaneScore& call) override;
  WimmSpec spec_;
  std::shared_ptr<const Constants> constants_;  // the kernel's, made from spec_ once
};

}  // namespace imm
