// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Scans of tracks planted by a test: the truth's state and a plot of it.

#include <Eigen/Dense>
#include <random>

#include "imm/datasets/track.hpp"

namespace imm::testing {

/// Scan k of `track`: the truth [x, vx, y, vy] into its truth columns (0, 1, 3, 4) and the plot
/// (x, y) with independent Gaussian errors of σ `sigma`, x's error drawn first.
inline void record_scan(datasets::Track& track, Eigen::Index k, const Eigen::Vector4d& truth,
                        double sigma, std::mt19937_64& rng,
                        std::normal_distribution<double>& normal) {
  track.truth(k, 0) = truth(0);
  track.truth(k, 1) = truth(1);
  track.truth(k, 3) = truth(2);
  track.truth(k, 4) = truth(3);
  track.plots(k, 0) = truth(0) + sigma * normal(rng);
  track.plots(k, 1) = truth(2) + sigma * normal(rng);
}

}  // namespace imm::testing
