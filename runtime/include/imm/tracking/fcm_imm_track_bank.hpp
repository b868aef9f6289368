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
#include "imm/tracking/lane_storage.hpp"

namespace imm {

/// N tracks of one FCM-IMM with Cartesian plots, stepped together (see the file comment).
class IMM_RUNTIME_EXPORT FcmImmTrackBank : public LaneStorage {
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
  /// InvalidParameter("state") for a non-finite state.
  void initialize(std::size_t track, const GaussianState<4>& state);

  /// One scan of tracks 0 … plots.size() − 1, track t with plots[t]; status[t] receives its
  /// outcome (a track whose status is not kOk is unchanged). Tracks from plots.size() on are not
  /// touched. Throws std::invalid_argument when the spans differ in size or exceed capacity(),
  /// std::logic_error when a stepped track was never initialized.
  void step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status);

  /// step(), stating each stepped track's normalized innovation squared into nis[t] as
  /// GaFuzzyTrackBank::step with `nis` does (each mode's ν_j = e and S_j of its update), what
  /// last_step_nis gives the one-track filter after the same step; NaN where status[t] is not kOk.
  /// Throws as step(), and std::invalid_argument when `nis` differs in size from `plots`.
  void step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status,
            std::span<double> nis);

  /// The gating question for many tracks and plots in one call, without changing any track:
  /// out(t, q) = log p(z_q | Z_t) of candidate plot q under track t (each axis's
  /// log Σ_j c_j N_j of a trial step of every mode: the window's clustering reads the plot's
  /// error), for tracks 0 … out.rows() − 1; −∞ where the plot's squared distance to the
  /// prediction without a plot (uncompensated, collapsed) is above `gate`; NaN for an unusable
  /// plot or a prediction that cannot score it — the one-track filter's candidate_log_likelihood
  /// and candidate_distance after predict(), as closely as the bank follows the filter. The
  /// windows are not changed: step() with the plots chosen gives the same numbers as without this
  /// call. Throws as GaFuzzyTrackBank::candidate_log_likelihoods. Nothing is allocated.
  void candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots, double gate,
                                 Eigen::Ref<Eigen::MatrixXd> out);
  /// The same with track t gated at gate × gate_scale[t] (CalibratedTrackBank); throws as
  /// GaFuzzyTrackBank's.
  void candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots, double gate,
                                 std::span<const double> gate_scale,
                                 Eigen::Ref<Eigen::MatrixXd> out);

  /// The combined estimate [x, vx, y, vy] (block-diagonal covariance: the axes are independent).
  [[nodiscard]] GaussianState<4> estimate(std::size_t track) const;

  /// μ of the x axis's IMM, then the y axis's (TwoAxisFilter::mode_probabilities).
  [[nodiscard]] ModeVector mode_probabilities(std::size_t track) const;

 private:
  // step(), with the NIS where `nis` is not null.
  void step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status, double* nis);
  // The gating matrix once the arguments are checked; gate_scale: a factor per track, or null.
  void score(std::span<const Eigen::Vector2d> plots, double gate, const double* gate_scale,
             Eigen::Ref<Eigen::MatrixXd> out);
  // Slot of entry `entry` of mode `mode`'s window (after every mode's cycle slots).
  [[nodiscard]] int window_slot(int mode, int entry) const;

  FcmImmSpec spec_;
  int window_slots_ = 0;                // window slots per mode
  std::vector<double> transition_;      // π_ij at i * modes + j
  std::vector<double> log_transition_;  // log π_ij likewise
  std::vector<double> scratch_;         // one lane's window and memberships for the clustering
  std::vector<double> innovations_;     // a step's modes' innovations where it states its NIS
};

}  // namespace imm
