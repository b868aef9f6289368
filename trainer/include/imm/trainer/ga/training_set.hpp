// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Training data for the fuzzy rule tables: the one-axis trajectories of a regime's split (the
/// fuzzy-noise KF is a per-axis filter, so every 2-D track gives its x and its y axis), with the
/// sample period and the plot variance the filters run with.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "imm/datasets/axis_trajectory.hpp"
#include "imm/datasets/regime.hpp"

namespace imm::trainer::ga {

using datasets::AxisTrajectory;

struct TrainingSet {
  std::vector<AxisTrajectory> trajectories;
  double sample_period = 1.0;
  double measurement_variance = 0.25;
  /// SHA-256 of the measurements and truth (for the model's dataset_digest).
  [[nodiscard]] std::string digest() const;
  [[nodiscard]] long total_steps() const;
};

/// The one-axis trajectories of a split of the regime (the training and validation splits use the
/// regime's own seed).
[[nodiscard]] TrainingSet make_training_set(const datasets::Regime& regime, datasets::Split split);

}  // namespace imm::trainer::ga
