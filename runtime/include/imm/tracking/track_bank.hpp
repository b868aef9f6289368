// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Many independent tracks of one plain IMM, stepped by one call: the structure of a radar
/// tracker (thousands of tracks, one model). Built from the same PlainImmSpec as the single-track
/// IMM (plain_imm.hpp) when every mode is constant-velocity and the measurement Cartesian, the
/// common case of air and ground surveillance: state [x, vx, y, vy], z = [x, y] + v.
///
/// Layout, and why: the tracks are stored in tiles of kBlock = 8 (a structure of arrays per
/// tile): entry e of mode j of the tile's lane l at slot (j, e) · 8 + l, so that a tile's state is
/// one contiguous run of whole, aligned cache lines. (A structure of arrays over the whole bank
/// puts a pack's 60-odd slots one capacity apart; at a capacity of 1 024 that is 8 KiB, and every
/// slot falls into the same set of the first-level cache.) One step is one function templated on
/// its number type (track_bank_kernel.cpp): a LanePack (imm/math/lane_math.hpp) steps eight
/// consecutive tracks at once, one per vector element, through the whole IMM cycle
/// (mode-probability prediction, mixing, prediction, Joseph update, posterior, combination) with
/// lane_log and lane_exp; a double steps the tracks left over, one at a time, through the same
/// statements. The instruction set (AVX-512 or AVX2 where the CPU has it, chosen at run time; SSE2
/// otherwise) changes how many instructions an element operation takes, not its result: a track's
/// arithmetic is the same sequence of IEEE operations in every lane and alone (no fused
/// multiply-add, no reassociation), so a track's result does not depend on its position, on the
/// number of tracks or on the instruction set: a bank of N tracks equals N banks of one track to
/// the bit.
///
/// Numerics are those of ImmEstimator: log-space mode probabilities (the scaled linear μ̃ of the
/// class comment there, kept from the previous posterior instead of recomputed), the Joseph-form
/// covariance update written out for the position-selecting H, and a track whose plot is unusable
/// or whose step fails (singular S, non-finite result, every likelihood zero) is left exactly as
/// it was, with its status. Covariances are stored as their upper triangle, so they are exactly
/// symmetric. Differences to ImmEstimator are rounding only (its fixed-size Eigen products sum in
/// another order); tests bound them against the textbook IMM.
///
/// Its step, gating and NIS calls are TrackBankCalls' (track_bank_calls.hpp). The step that states
/// each track's NIS collapses the modes' innovations of each pack in the kernel, after its cycle;
/// the gating matrix skips the pairs outside the gate eight tracks at a time. Nothing is allocated
/// after construction.

#include <Eigen/Core>
#include <cstddef>
#include <span>
#include <vector>

#include "imm/core/aligned_allocator.hpp"
#include "imm/estimation/gaussian_state.hpp"
#include "imm/estimation/step_status.hpp"
#include "imm/filters/plain_imm.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/track_bank_calls.hpp"

namespace imm {

/// N tracks of one plain IMM of CV modes with Cartesian plots, stepped together (structure of
/// arrays; see the file comment).
class IMM_RUNTIME_EXPORT TrackBank : public TrackBankCalls {
 public:
  /// The state dimension: [x, vx, y, vy].
  static constexpr int kDim = 4;
  /// Tracks per tile of the state (the widest pack); the state is padded to whole tiles.
  static constexpr int kBlock = 8;

  /// Room for `capacity` tracks of the IMM of `spec`. Throws InvalidParameter naming the field
  /// for an invalid spec, a mode that is not CV ("modes[i].motion") or a polar measurement
  /// ("measurement.kind").
  TrackBank(const PlainImmSpec& spec, std::size_t capacity);

  /// The number of IMM modes.
  [[nodiscard]] int mode_count() const { return modes_; }

  /// Starts (or restarts) track `track`: every mode takes `state`, the mode probabilities their
  /// initial values. Throws std::out_of_range for a track ≥ capacity(), InvalidParameter
  /// ("initial_state" / "initial_covariance") for a start the one-track filter refuses
  /// (require_initial_state: a non-finite mean, a covariance not finite and symmetric with a
  /// non-negative diagonal); nothing changes then.
  void initialize(std::size_t track, const GaussianState<kDim>& state);

  /// Makes the following cycles of every track (step, candidate_log_likelihoods) span `interval`
  /// s: each mode's F and Q and the mode transitions of the interval, as for one track
  /// (TrackFilter::set_interval, transition_over; one sample period: the spec's own numbers).
  /// False, and nothing changed, for an interval outside limits::kSamplePeriod. Nothing is
  /// allocated.
  bool set_interval(double interval);

  /// The combined estimate of a track (eq. 10–11).
  [[nodiscard]] GaussianState<kDim> estimate(std::size_t track) const;
  /// Mode j's own estimate of a track.
  [[nodiscard]] GaussianState<kDim> mode_estimate(std::size_t track, int j) const;
  /// μ_j (linear; may hold exact zeros after underflow) and log μ_j.
  [[nodiscard]] ModeVector mode_probabilities(std::size_t track) const;
  /// log μ_j of a track (finite where μ_j underflows to 0).
  [[nodiscard]] ModeVector log_mode_probabilities(std::size_t track) const;

 private:
  // Where slot `index` of track t (an index checked() gave) is in state_.
  [[nodiscard]] std::size_t offset(int index, std::ptrdiff_t t) const {
    return static_cast<std::size_t>(t / kBlock * tile_ + std::ptrdiff_t{index} * kBlock +
                                    t % kBlock);
  }
  [[nodiscard]] double& at(int index, std::ptrdiff_t t) { return state_[offset(index, t)]; }
  [[nodiscard]] double at(int index, std::ptrdiff_t t) const { return state_[offset(index, t)]; }
  // The state slot of entry `entry` of mode j / of the combined estimate (layout in the .cpp).
  [[nodiscard]] int mode_slot(int j, int entry) const;
  [[nodiscard]] int combined_slot(int entry) const;
  // The constants of a cycle of `interval` s with mode transitions `transition` (no allocation).
  void remake(double interval, const ModeMatrix& transition);
  // The kernel on the tile of tracks [first, first + lanes), lanes ≤ kBlock: their step with
  // `plots` (and, where `nis` is not null, their NIS), or, with `predict`, their predicted plot
  // densities into prediction_.
  void run_block(std::size_t first, int lanes, const Eigen::Vector2d* plots, StepStatus* status,
                 double* nis, bool predict = false);
  // TrackBankCalls' step (with `nis`, the kernel collapses each pack's recorded innovations after
  // its cycle) and gating matrix (pairs outside the gate skipped eight tracks at a time).
  void step_lanes(const LaneStep& call) override;
  void score_lanes(const LaneScore& call) override;

  int modes_ = 0;
  std::ptrdiff_t tile_ = 0;             // doubles per tile of the state (slots × kBlock)
  std::ptrdiff_t prediction_tile_ = 0;  // of prediction_
  double period_ = 1.0;         // the interval of a cycle (the sample period until set_interval)
  double sample_period_ = 1.0;  // the spec's
  ModeMatrix per_period_;       // Π over one sample period
  std::vector<MotionParameters> motion_;  // per mode, what F and Q are made from
  std::vector<double> transition_;        // π_ij at i * modes + j
  std::vector<double> log_transition_;
  std::vector<double> initial_log_mu_;
  std::vector<double> noise_;  // per mode, Q's upper triangle (10)
  double r00_ = 0.0, r01_ = 0.0, r11_ = 0.0;

  std::vector<double, AlignedAllocator<double>> state_;  // whole tiles
  // candidate_log_likelihoods' predicted plot densities, in tiles as the state
  std::vector<double, AlignedAllocator<double>> prediction_;
  // A step that states the NIS: one pack's predicted log c_j and the modes' innovations
  std::vector<double> innovations_;
};

}  // namespace imm
