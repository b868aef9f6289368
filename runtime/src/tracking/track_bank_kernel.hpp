// SPDX-License-Identifier: Apache-2.0
#pragma once
// The TrackBank's kernel (track_bank_kernel.cpp): one IMM step of a block of tracks stored
// structure-of-arrays, written once for a number type that is a pack of tracks or one track.
// Not installed.

#include <Eigen/Core>
#include <cstddef>

#include "estimation/cv_position_algebra.hpp"
#include "imm/math/linear_algebra.hpp"
#include "imm/tracking/lane_storage.hpp"
#include "imm/tracking/track_bank.hpp"

namespace imm::bank {

using cv_position::kEntries;
using cv_position::kN;
using cv_position::kTriangle;
using cv_position::sym;
static_assert(kN == TrackBank::kDim);
// State slots per mode: mean, covariance upper triangle, log μ, μ̃ = μ / max μ; the combined
// estimate (mean, triangle) follows the modes.
constexpr int kMean = 0, kCov = kN, kLogMu = kEntries, kScaledMu = kEntries + 1,
              kModeSlots = imm_mode_slot(1, kEntries, 0);
// The doubles a step that states the NIS keeps of one pack (track_bank_kernel.cpp).
constexpr std::ptrdiff_t kInnovationDoubles = std::ptrdiff_t{6} * kMaxModes * 8;
// What one block's step reads and writes: the bank's constants and its state slots (stride apart,
// already offset to the block's first track).
struct Block {
  int modes = 0;
  int lanes = 0;
  double period = 1.0;
  const double* transition = nullptr;
  const double* log_transition = nullptr;
  const double* noise = nullptr;
  double r00 = 0.0, r01 = 0.0, r11 = 0.0;
  double* state = nullptr;
  std::ptrdiff_t stride = 0;
  const Eigen::Vector2d* plots = nullptr;
  StepStatus* status = nullptr;
  double* nis = nullptr;  // where not null, each track's NIS of the step (offset to the first)
  double* innovations = nullptr;  // with `nis`: kInnovationDoubles for the packs' innovations
};

/// One IMM step (seed 000 eq. 4–11) of the tracks of block `b`; a track whose plot is unusable or
/// whose step fails keeps its state and gets its StepStatus. Where `b.nis` is not null, each
/// track's NIS: ν̄ᵀ S̄⁻¹ ν̄ of the modes' ν_j and S_j of the update collapsed with the normalized
/// predicted c_j (ImmEstimator::innovation after the step), NaN where the step failed or S̄ is not
/// positive definite.
void step_tracks(const Block& b);

// The predicted plot density of a track, for candidate plots: per mode j the constant
// log c_j − ½ log|S_j| − log 2π, ẑ_j and S_j⁻¹'s triangle (kPlotSlots), then the collapsed
// prediction's ẑ and S̄⁻¹'s triangle (kCollapsedSlots).
constexpr int kPlotSlots = 6, kCollapsedSlots = 5;

/// The first half of the cycle of block `b`'s tracks (mixing and prediction; `b.plots` and
/// `b.status` unused): their predicted plot densities into `prediction` (slots `b.stride` apart,
/// offset to the block's first track). The state is not changed.
void predict_plots(const Block& b, double* prediction);

// Candidate plots against tracks [0, tracks) whose predictions predict_plots wrote.
struct Scoring {
  int modes = 0;
  int tracks = 0;
  const double* prediction = nullptr;
  std::ptrdiff_t stride = 0;
  const Eigen::Vector2d* plots = nullptr;
  int plot_count = 0;
  double gate = 0.0;
  const double* gate_scale = nullptr;  // per track, offset to the first; null: every factor 1
  double* out = nullptr;               // plot q of track t at out[q * out_stride + t]
  std::ptrdiff_t out_stride = 0;
};

/// Every (track, plot) log-likelihood log Σ_j c_j N(z; ẑ_j, S_j), −∞ where the collapsed
/// distance exceeds the gate.
void score_plots(const Scoring& s);

}  // namespace imm::bank
