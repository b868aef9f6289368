// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Training data for the fuzzy rule tables: the one-axis trajectories of a regime's split (the
/// fuzzy-noise KF is a per-axis filter, so every 2-D track gives its x and its y axis), with the
/// sample period and the plot variance the filters run with.

#include <Eigen/Core>
#include <cmath>
#include <string>
#include <vector>

#include "imm/datasets/axis_trajectory.hpp"
#include "imm/datasets/regime.hpp"
#include "imm/math/log_sum_exp.hpp"

namespace imm::trainer {

using datasets::AxisTrajectory;

struct TrainingSet {
  std::vector<AxisTrajectory> trajectories;
  double sample_period = 0.0;  ///< T, s: the regime's
  double measurement_variance = 0.25;
  /// No truth to learn from (a recorded regime without truth for training): the trajectories'
  /// positions and velocities are NaN, and every score is the plots' predictive NLL instead of
  /// an error against truth (axis_zetas, ImmFitnessBatch).
  bool plots_only = false;
  /// What the tuners minimize on this set, for messages: "ζ_p + ζ_v" or "excess NLL per plot".
  [[nodiscard]] const char* criterion() const {
    return plots_only ? "excess NLL per plot" : "ζ_p + ζ_v";
  }
  /// The plots' own entropy per plot, ½ log(2π e σ²): the NLL of a filter that knew every
  /// position. Without truth the tuners and the GA minimize the excess NLL per plot over it — the
  /// same optimum as the NLL, on ζ's scale (a few tenths for a good filter), so that eq. (16)'s
  /// "error + 1" and the trainers' quality gates keep their meaning.
  [[nodiscard]] double nll_floor() const {
    return 0.5 * (kLogTwoPiE + std::log(measurement_variance));
  }
  /// SHA-256 of the measurements and truth (for the model's dataset_digest).
  [[nodiscard]] std::string digest() const;
  [[nodiscard]] long total_steps() const;
};

/// The one-axis trajectories of a split of the regime (the training and validation splits use the
/// regime's own seed). A recorded regime without truth for training gives a plots_only set; its
/// windows must be free of gaps (std::runtime_error naming the recording otherwise).
[[nodiscard]] TrainingSet make_training_set(const datasets::Regime& regime, datasets::Split split);

}  // namespace imm::trainer
