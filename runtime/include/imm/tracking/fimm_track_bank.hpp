// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Many independent tracks of one fuzzy-sensor IMM (fimm.hpp), stepped by one call: the
/// multi-track form of FimmFilter, as TrackBank is of the plain IMM.
///
/// Layout: every track is a lane (its two CA modes' means and covariances' upper triangles, and
/// log μ), stored structure of arrays and stepped 8 at a time. A step runs per block:
///   1. vector loops: the predicted mode probabilities, the mixing and both modes' predictions;
///   2. per mode, vector loops that evaluate the TSK sensor model (h and its Jacobian at the
///      predicted position: TskSensorModel::evaluate's operations in its order) and make the
///      Joseph-form update; the iterated EKF repeats both from the relinearized point, lane by
///      lane until its step is below the tolerance (kIteratedUpdateTolerance) or the iterations
///      are spent, as iterated_update does;
///   3. vector loops: the posterior μ and the commit.
/// The vector loops have no branches and no calls, and the compiler vectorizes them: AVX-512 or
/// AVX2 where the CPU has it, chosen at run time, without fused multiply-add, so a track's result
/// does not depend on the instruction set, on its position or on the number of tracks.
///
/// The differences to the one-track filter are rounding only: exp and log (the mode probabilities,
/// the TSK rules' weights) are lane_exp and lane_log (lane_math.hpp, within 2 ulp of libm's), and
/// the products sum only H's non-zero entries. A track whose plot is unusable, or whose step fails
/// in either mode, is left exactly as it was, with the status of the first mode that failed
/// (cruise, then lane change), as the one-track filter reports it.
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
#include "imm/filters/fimm.hpp"
#include "imm/models/learned/tsk_sensor_model.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/two_mode_lane_storage.hpp"

namespace imm {

/// N tracks of one FIMM with plots in the sensor's (z1, z2), stepped together (see the file
/// comment).
class IMM_RUNTIME_EXPORT FimmTrackBank : public TwoModeLaneStorage {
 public:
  /// Tracks per block of the layout.
  static constexpr int kBlock = 8;

  /// Room for `capacity` tracks of `spec` through `sensor` (null: h = identity, the baseline IMM,
  /// as FimmFilter). Throws InvalidParameter naming the field for an invalid spec
  /// (FimmSpec::validate), a transition probability that is not positive ("transition") or a
  /// capacity outside [1, 2^26].
  FimmTrackBank(const FimmSpec& spec, std::shared_ptr<const TskSensorModel> sensor,
                std::size_t capacity);

  /// Starts (or restarts) track `track` from `state` ([ξ, ξ̇, ξ̈, η, η̇, η̈]): both modes take it, μ
  /// its initial value (FimmFilter::initialize). Throws std::out_of_range for a track ≥
  /// capacity(), InvalidParameter("initial_state" / "initial_covariance") for a start the
  /// one-track filter refuses (require_initial_state).
  void initialize(std::size_t track, const GaussianState<6>& state);

  // estimate(track) is [ξ, ξ̇, ξ̈, η, η̇, η̈] (FimmFilter::estimate), mode_probabilities(track)
  // μ = (cruise, lane change): TwoModeLaneStorage's.

  // step(), step() with the NIS and candidate_log_likelihoods() are TrackBankCalls'.

 private:
  struct Constants;
  // One scan of the tracks (plots in the sensor's (z1, z2)); with `nis`, the modes' ν_j and S_j
  // of the update collapsed with the predicted c_j: the one-track FIMM's last_step_nis to
  // rounding.
  void step_lanes(const LaneStep& call) override;
  // log Σ_j c_j N(ν_j; 0, S_j) of the candidate under the prediction (each mode's first
  // linearization of the sensor model there), gated by its squared distance to the collapsed
  // predicted plot: the one-track FIMM's candidate questions after predict(), to rounding.
  void score_lanes(const LaneScore& call) override;
  FimmSpec spec_;
  std::shared_ptr<const TskSensorModel> sensor_;
  std::shared_ptr<const Constants> constants_;  // the kernel's, made from spec_ and sensor_ once
};

}  // namespace imm
