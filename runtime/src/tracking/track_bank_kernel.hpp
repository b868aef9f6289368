// SPDX-License-Identifier: Apache-2.0
#pragma once
// The TrackBank's kernel (track_bank_kernel.cpp): one IMM step of a block of tracks stored
// structure-of-arrays, phase by phase over the block's lanes. Not installed.

#include <Eigen/Core>
#include <cstddef>

#include "estimation/cv_position_algebra.hpp"
#include "imm/tracking/track_bank.hpp"

namespace imm::bank {

using cv_position::kEntries;
using cv_position::kN;
using cv_position::kTriangle;
using cv_position::sym;
constexpr std::ptrdiff_t kB = TrackBank::kBlock;
static_assert(kN == TrackBank::kDim);
// State slots per mode: mean, covariance upper triangle, log μ, μ̃ = μ / max μ; the combined
// estimate (mean, triangle) follows the modes.
constexpr int kMean = 0, kCov = kN, kLogMu = kEntries, kScaledMu = kEntries + 1,
              kModeSlots = kEntries + 2;
// What one block's phases read and write: the bank's constants, its state slots (stride apart,
// already offset to the block's first track) and the block's scratch (kB apart).
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
  double* scratch = nullptr;
  const Eigen::Vector2d* plots = nullptr;
  StepStatus* status = nullptr;
};

// Scratch layout, in slots of kB values.
struct ScratchLayout {
  int weights, log_predicted, predicted, mixed, updated, determinant, mahalanobis, s00, threshold,
      finite, zx, zy, posterior, new_log_mu, new_scaled_mu, ok, shift, total;
  explicit ScratchLayout(int n)
      : weights(0),
        log_predicted(n * n),
        predicted(log_predicted + n),
        mixed(predicted + n),
        updated(mixed + n * kEntries),
        determinant(updated + n * kEntries),
        mahalanobis(determinant + n),
        s00(mahalanobis + n),
        threshold(s00 + n),
        finite(threshold + n),
        zx(finite + n),
        zy(zx + 1),
        posterior(zy + 1),
        new_log_mu(posterior + n),
        new_scaled_mu(new_log_mu + n),
        ok(new_scaled_mu + n),
        shift(ok + 1),
        total(shift + 1) {}
};

/// One IMM step (seed 000 eq. 4–11) of the tracks of block `b`; a track whose plot is unusable or
/// whose step fails keeps its state and gets its StepStatus.
void step_tracks(const Block& b);

}  // namespace imm::bank
