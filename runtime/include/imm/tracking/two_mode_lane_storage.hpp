// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The lane storage of the banks of two-mode IMMs whose modes mix in the 6-state space
/// [x, vx, ax, y, vy, ay] (WimmTrackBank, FimmTrackBank): where each mode's mean, its covariance's
/// upper triangle and log μ sit in a lane, and what reads and starts a track from them, once for
/// both banks. The kernels that step the lanes are each bank's own.

#include <Eigen/Core>
#include <cstddef>

#include "imm/estimation/gaussian_state.hpp"
#include "imm/math/linear_algebra.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/lane_storage.hpp"

namespace imm {

/// Lanes of two modes in the 6-state mixing space (see the file comment).
class IMM_RUNTIME_EXPORT TwoModeLaneStorage : public LaneStorage {
 public:
  /// The combined estimate of a track: both modes embedded in the 6-state space (zero where a
  /// mode has no acceleration) and moment-matched with μ (ImmEstimator::combine). Throws
  /// std::out_of_range for a track ≥ capacity().
  [[nodiscard]] GaussianState<6> estimate(std::size_t track) const;
  /// μ of a track, in the order of the modes. Throws as estimate().
  [[nodiscard]] ModeVector mode_probabilities(std::size_t track) const;

  /// Where a mode sits in a lane.
  struct ModeLayout {
    int axis_states = 0;  ///< its states per axis: 2 (position, velocity) or 3 (and acceleration)
    int mean = 0;         ///< its mean's first slot (the states axis by axis)
    int covariance = 0;   ///< its covariance's first slot (the upper triangle row by row)
  };

 protected:
  /// Bank `name`'s layout of both modes and of log μ (slots `log_mu` and `log_mu` + 1).
  TwoModeLaneStorage(std::string_view name, ModeLayout first, ModeLayout second, int log_mu)
      : LaneStorage(name), first_(first), second_(second), log_mu_(log_mu) {}

  /// Starts track `track` (ImmEstimator::initialize): both modes take their components of
  /// `state`, log μ the log of `initial`; returns the track's lane. Throws std::out_of_range for a
  /// track ≥ capacity(), InvalidParameter("initial_state" / "initial_covariance") for a start the
  /// one-track filter refuses (require_initial_state). The caller
  /// sets its own slots and then marks the track initialized.
  std::ptrdiff_t start(std::size_t track, const GaussianState<6>& state,
                       const Eigen::Vector2d& initial);

 private:
  ModeLayout first_, second_;
  int log_mu_ = 0;
};

}  // namespace imm
