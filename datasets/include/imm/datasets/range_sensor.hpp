// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Seed 002's distorted long-range sensor (SPEC §7). Units m.
///
/// Distortion (ours; the seed shows only its data, Fig. 3): the range compresses beyond a knee,
///   η_m = η                               for η ≤ knee,
///   η_m = knee + L tanh((η − knee) / L)   beyond,
/// and the lateral coordinate is scaled by the same ratio, ξ_m = ξ η_m / η; plus white noise.
/// The default knee is 40 m and L = 30 m (the "hard" sensor: L = 10 m, where the range is nearly
/// unobservable beyond ~60 m: dη_m/dη = sech²(2) ≈ 0.07 at 60 m). A regime's range sensor
/// (imm/datasets/regime.hpp) is this distortion or a sensor known through samples.

#include <Eigen/Core>

namespace imm::datasets {

struct RangeDistortion {
  double knee = 40.0;      ///< m
  double softness = 30.0;  ///< L, m
  /// Throws InvalidParameter naming the field.
  void validate() const;
  /// The noise-free sensor output (ξ_m, η_m) of a position (ξ, η).
  [[nodiscard]] Eigen::Vector2d apply(const Eigen::Vector2d& position) const;
};

/// Sensor samples: true positions and the sensor's outputs.
struct RangeSensorData {
  Eigen::MatrixXd positions;  ///< samples × 2: true (ξ, η)
  Eigen::MatrixXd outputs;    ///< samples × 2: measured (z₁, z₂)
};

}  // namespace imm::datasets
