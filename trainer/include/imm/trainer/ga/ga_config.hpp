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
#include "imm/trainer/training_set.hpp"

namespace imm::trainer::ga {

/// The constant-q IMM a `levels = "tuned"` run starts from (baseline_tuning.hpp), tuned on the
/// training split: its noise levels and stay probability, and its ζ_p + ζ_v there.
struct TunedBaseline {
  std::vector<double> process_noise;  ///< q_j, (unit/s²)²
  double transition_stay = 0.0;
  double score = 0.0;
  int evaluations = 0;
};

struct GaTrainingConfig {
  std::uint64_t seed = 1;
  datasets::Regime regime;
  /// The IMM the tables serve; sample period and plot σ are the regime's.
  AxisImmSettings filter;
  /// Maneuver levels a_M, one table each, in the regime's acceleration unit. By default
  /// (`levels = "auto"`) `level_count` levels log-spaced from the regime's smallest to its largest
  /// commanded acceleration. `levels = "tuned"`: empty until resolve_levels() fills it with the
  /// tuned IMM's √q_j (see tuned_levels).
  std::vector<double> levels;
  /// `levels = "tuned"`: the trainer first tunes a constant-q IMM of `level_count` modes and its
  /// stay probability on the training split (the evaluation's IMM-tuned, tune_axis_cv_imm with
  /// TransitionTuning::kJointly), takes its √q_j as the levels and its p_jj as the filter's, and
  /// seeds every level's GA with the one-rule table q = q_j: the GA then starts from — and by
  /// elitism never falls below — the tuned IMM, and the consequents range over
  /// consequent_range × √q_j. The paper's form ("auto" or a list) uses a_M + √q of eq. (15).
  bool tuned_levels = false;
  int level_count = 3;
  /// Set by resolve_levels() for tuned levels.
  std::optional<TunedBaseline> baseline;
  /// `[training] refine_levels`: after the tables, Subplex scales every table's consequents (one
  /// factor per level) and the stay probability together on the IMM fitness's error — the levels
  /// and transitions trained with the tables; by ζ_p + ζ_v, kept only when it improves.
  bool refine_levels = false;
  ProblemOptions fuzzy;  ///< maneuver_level and process_noise_sigma are set per level
  GaOptions ga;
  MemeticOptions memetic;
  double max_validation_error = 1.0;  ///< quality gate per level (eq. 17 over σ_z)

  std::string text;  ///< the config file's text (provenance)
  std::string name;  ///< the config file's name

  /// Throws InvalidParameter naming the key ("ga.lambda").
  void validate() const;
  /// The options of level i's problem (tuned levels: √w in units of √q_j alone).
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
