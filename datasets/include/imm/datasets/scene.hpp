// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Scenes: several targets of a regime at once, each detected with a probability, among Poisson
/// clutter — what a multi-target tracker meets (imm-data scenes, imm-eval multi-target). A
/// scene's targets are tracks of a split drawn as any other (track.hpp); its detections and
/// clutter come from their own stream of the seed, so scene i depends only on (regime, settings,
/// split, seed, i).

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "imm/datasets/regime.hpp"
#include "imm/datasets/track.hpp"

namespace imm::datasets {

/// One scene's targets, and per scan its plots: detections and false plots in random order, each
/// with its origin.
struct Scene {
  std::vector<Track> targets;
  /// Per scan, the plots in the sensor's plot space (Cartesian x, y or polar range, azimuth).
  std::vector<std::vector<Eigen::Vector2d>> plots;
  /// Per scan and plot, the target it comes from (an index into `targets`), or −1 for clutter.
  std::vector<std::vector<int>> origins;
  /// The box the clutter is uniform over, in plot space: the targets' plots' box widened by a
  /// tenth on each side.
  Eigen::Vector2d low = Eigen::Vector2d::Zero(), high = Eigen::Vector2d::Zero();
};

/// Scene `index` of a split: targets `index · targets + j` of the split (j < targets), each plot
/// kept with probability Pd, Poisson(λ) false plots per scan uniform over the targets' plot box.
/// Throws InvalidParameter naming the field of invalid settings (SceneSpec::validate).
[[nodiscard]] Scene draw_scene(const Regime& regime, const SceneSpec& spec, Split split, int index,
                               std::uint64_t seed);

}  // namespace imm::datasets
