// SPDX-License-Identifier: Apache-2.0
#pragma once
/// `configs/ga_fuzzy_imm.toml`: everything `imm-train ga` needs, one options struct per component,
/// keys one to one with fields (see the shipped config for every key and its meaning). The regime
/// (`regime = …`) gives the training data and what the filter is built for — the sample period,
/// the plot σ, the truth's process noise √q of eq. (15) — and the maneuver levels by default.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "imm/datasets/regime.hpp"
#include "imm/filters/axis_filter.hpp"
#include "imm/trainer/ga/fuzzy_table_problem.hpp"
#include "imm/trainer/ga/genetic_algorithm.hpp"
#include "imm/trainer/ga/memetic.hpp"
#include "imm/trainer/ga/training_set.hpp"

namespace imm::trainer::ga {

struct GaTrainingConfig {
  std::uint64_t seed = 1;
  datasets::Regime regime;
  /// The IMM the tables serve; sample period and plot σ are the regime's.
  AxisImmSettings filter;
  /// Maneuver levels a_M, one table each, in the regime's acceleration unit. By default
  /// (`levels = "auto"`) `level_count` levels log-spaced from the regime's smallest to its largest
  /// commanded acceleration.
  std::vector<double> levels;
  ProblemOptions fuzzy;  ///< maneuver_level and process_noise_sigma are set per level
  GaOptions ga;
  MemeticOptions memetic;
  double max_validation_error = 1.0;  ///< quality gate per level (eq. 17 over σ_z)

  std::string text;  ///< the config file's text (provenance)
  std::string name;  ///< the config file's name

  /// Throws InvalidParameter naming the key ("ga.lambda").
  void validate() const;
  /// The options of level i's problem.
  [[nodiscard]] ProblemOptions problem_options(std::size_t level) const;
};

/// Loads and validates; unknown keys, wrong types and out-of-range values are ConfigErrors naming
/// the file and the key. `regime` replaces the config's regime.
[[nodiscard]] GaTrainingConfig load_ga_config(
    const std::filesystem::path& path,
    const std::optional<std::filesystem::path>& regime = std::nullopt);

/// `count` levels log-spaced over the regime's commanded accelerations (the smallest and the
/// largest); one level when they coincide. Throws InvalidParameter ("training.levels") for a
/// regime without maneuvers.
[[nodiscard]] std::vector<double> automatic_levels(const datasets::Regime& regime, int count);

}  // namespace imm::trainer::ga
