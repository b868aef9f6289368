// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Many independent tracks of one FCM-IMM (fcm_imm.hpp), stepped by one call: the multi-track
/// form of make_fcm_imm_filter, as TrackBank is of the plain IMM.
///
/// Layout: every track is two axis filters (x, then y), every axis filter a lane; lanes are
/// stored structure of arrays (each mode's estimate and log μ, then each mode's clustering window,
/// head, size and centers) and stepped 8 at a time. A step runs per block the IMM cycle every bank
/// runs (runtime/src/tracking/imm_cycle.hpp: the predicted mode probabilities, the mixing, each
/// mode's step, the posterior μ and the commit over packs of lanes), with this family's mode step:
///   1. lanes::fcm_predict over a pack of the block's lanes (fcm_mode_step.hpp, the step
///      FcmCompensatedMode runs for a double): the CV prediction, the error e and S;
///   2. one scalar loop over the lanes: the sliding fuzzy c-means of the errors (cluster_window,
///      the clustering SlidingFuzzyCMeans runs, on the bank's windows: the same memberships to the
///      bit);
///   3. lanes::fcm_update over the pack (the compensated-gain Joseph update and its likelihood);
/// then the committed lanes' windows and centers. The vector parts have no branches, and the
/// compiler vectorizes them: AVX-512 or AVX2 where the CPU has it, chosen at run time, without
/// fused multiply-add, so a track's result does not depend on the instruction set, on its
/// position or on the number of tracks.
///
/// The clustering iterates to its tolerance per lane and mode, so it keeps its one-track cost;
/// the bank speeds up the rest of the step (fcm_imm's profile: about 56 % of a one-track step is
/// the clustering). The clustering stops where max |ΔU| first falls below the tolerance, a rule a
/// change in the last bit of an error can move by an iteration (and the memberships by up to the
/// tolerance); so the bank computes the errors with the one-track filter's operations in its
/// order — the mode probabilities with ImmEstimator's arithmetic (imm_cycle.hpp's
/// kLibmProbabilities: libm's exp and log, μ̃ from log μ) rather than lane_exp and lane_log — and
/// its results differ from the one-track filter's by rounding only (the tests hold them to 1e-9;
/// the mixing's Eigen products may round differently). A track whose plot is unusable, or whose x
/// or y step fails, is left exactly as it was, both axes, with the status of the first axis that
/// failed.
///
/// Every transition probability must be positive: c_j then never vanishes, so no mode is ever
/// unreachable. Nothing is allocated after construction.

#include <Eigen/Core>
#include <cstddef>
#include <span>
#include <vector>

#include "imm/estimation/gaussian_state.hpp"
#include "imm/estimation/step_status.hpp"
#include "imm/filters/fcm_imm.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/axis_imm_lane_storage.hpp"

namespace imm {

/// N tracks of one FCM-IMM with Cartesian plots, stepped together (see the file comment).
class IMM_RUNTIME_EXPORT FcmImmTrackBank : public AxisImmLaneStorage {
 public:
  /// Axis lanes per block of the layout (four tracks).
  static constexpr int kBlock = 8;

  /// Room for `capacity` tracks of `spec`. Throws InvalidParameter naming the field for an invalid
  /// spec (FcmImmSpec::validate), a transition probability that is not positive ("transition") or
  /// a capacity outside [1, 2^26].
  FcmImmTrackBank(const FcmImmSpec& spec, std::size_t capacity);

  /// Starts (or restarts) track `track` from [x, vx, y, vy] (the covariance's two axis blocks):
  /// every mode of each axis takes the state, μ its initial value, the clusterings empty windows
  /// (make_fcm_imm_filter's initialize). Throws std::out_of_range for a track ≥ capacity(),
  /// InvalidParameter("initial_state" / "initial_covariance") for a start the one-track filter
  /// refuses (require_initial_state).
  void initialize(std::size_t track, const GaussianState<4>& state);

  /// The modes of each axis moment-matched with μ [x, vx, y, vy] (block-diagonal covariance).
  [[nodiscard]] GaussianState<4> estimate(std::size_t track) const;

  // mode_count() and mode_probabilities() are AxisImmLaneStorage's; step(), step() with the NIS
  // and candidate_log_likelihoods() TrackBankCalls'.

 private:
  // One scan of the tracks; with `nis`, each mode's ν_j = e and S_j of its update collapsed with
  // the predicted c_j (the one-track filter's last_step_nis, to the bit).
  void step_lanes(const LaneStep& call) override;
  // Each axis's log Σ_j c_j N_j of a trial step of every mode (the window's clustering reads the
  // plot's error), gated by the squared distance to the prediction without a plot
  // (uncompensated, collapsed): the one-track filter's candidate questions after predict(), as
  // closely as the bank follows the filter. The windows are not changed.
  void score_lanes(const LaneScore& call) override;
  // Slot of entry `entry` of mode `mode`'s window (after every mode's cycle slots).
  [[nodiscard]] int window_slot(int mode, int entry) const;

  FcmImmSpec spec_;
  int window_slots_ = 0;             // window slots per mode
  std::vector<double> scratch_;      // one lane's window and memberships for the clustering
  std::vector<double> innovations_;  // a step's modes' innovations where it states its NIS
};

}  // namespace imm
