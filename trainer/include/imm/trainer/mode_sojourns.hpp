// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Mode transitions learned from tracks: the generator of a continuous-time chain of modes
/// (imm/estimation/mode_transitions.hpp) estimated from per-scan mode labels sampled every T
/// seconds. The discrete chain's maximum-likelihood transition matrix P̂ (n_ij / n_i, counted over
/// every scan-to-scan step) is mapped back to continuous time by Q̂ = log(P̂) / T, so that the
/// estimate has no O(qT) bias from jumps between samples; a rate the logarithm makes negative
/// (sampling noise around zero) is clamped to zero and its row rebalanced.

#include <Eigen/Core>
#include <span>
#include <vector>

#include "imm/datasets/track.hpp"

namespace imm::trainer {

struct SojournEstimate {
  Eigen::MatrixXd generator;       ///< Q̂, rows summing to zero (1/s)
  Eigen::VectorXd mean_sojourn;    ///< −1 / q̂_ii, seconds (∞ for a mode never left)
  Eigen::VectorXd standard_error;  ///< of the mean sojourn: τ̂ / √(exits), seconds
  Eigen::VectorXi exits;           ///< observed changes out of each mode
  Eigen::VectorXd time;            ///< seconds observed in each mode (scan-to-scan steps × T)
};

/// From `labels` (one sequence per track, each entry the mode of that scan, 0 … modes − 1) with
/// sample period `sample_period`. Throws InvalidParameter naming the problem: a label out of
/// range, a mode never observed, a sample period out of range.
[[nodiscard]] SojournEstimate estimate_sojourns(std::span<const std::vector<int>> labels, int modes,
                                                double sample_period);

/// Two modes from the truth of a regime's tracks: 0 while no maneuver acts, 1 while one does
/// (datasets::Track::maneuvering).
[[nodiscard]] SojournEstimate estimate_maneuver_sojourns(const datasets::TrackSet& tracks);

}  // namespace imm::trainer
