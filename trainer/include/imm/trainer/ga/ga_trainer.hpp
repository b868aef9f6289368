// SPDX-License-Identifier: Apache-2.0
#pragma once
/// `imm-train ga`: one rule table per maneuver level by the genetic algorithm (+ the optional
/// memetic polish), checkpointed after every generation, written as one "ga_fuzzy_imm" model file
/// with `<model>.metrics.json` beside it.
///
/// Checkpoints (`<model>.checkpoint`, written atomically, each while the next generation runs)
/// hold the finished levels and the current level's evaluated population; `--resume` continues from
/// them to the same final model as an uninterrupted run (the GA draws its random numbers per
/// generation, see genetic_algorithm.hpp). A checkpoint of another config or seed is refused.

#include <filesystem>
#include <functional>
#include <optional>
#include <vector>

#include "imm/filters/ga_fuzzy_imm.hpp"
#include "imm/trainer/ga/ga_config.hpp"
#include "imm/trainer/ga/tuned_levels.hpp"

namespace imm::trainer::ga {

struct GenerationLog {
  int generation = 0;
  double best_fitness = 0.0;
  double mean_fitness = 0.0;
  double best_error = 0.0;
  int best_rules = 0;
};

struct LevelResult {
  double maneuver_level = 0.0;
  FuzzyRuleTable table;
  Evaluation training;        ///< of the final table
  Evaluation validation;      ///< on the held-out trajectories
  Evaluation before_memetic;  ///< the GA's best, before polishing
  int memetic_evaluations = 0;
  int generations = 0;
  double wall_seconds = 0.0;
  std::array<double, 4> residual_ranges{};  ///< r_min, r_max, Δr_min, Δr_max
  std::vector<GenerationLog> history;
  std::string training_digest;
};

struct GaRunOptions {
  std::filesystem::path out = "models/ga_fuzzy_imm.h5";
  bool resume = false;
};

struct GaObserver {
  /// After every generation (level index, the generation's log, seconds since the level started).
  std::function<void(std::size_t level, const GenerationLog& log, double seconds)> on_generation;
  std::function<void(std::size_t level, const LevelResult& result)> on_level_done;
  std::function<void(std::size_t level, int generation)> on_resume;
  /// Polled after each checkpoint; returning true stops the run there (as a kill would).
  std::function<bool()> should_stop;
};

struct GaTrainingResult {
  /// The config as trained: tuned levels resolved (resolve_levels), the refinement applied to the
  /// filter's stay probability.
  GaTrainingConfig config;
  std::vector<LevelResult> levels;
  std::optional<LevelRefinement> refinement;
  std::optional<BaselineCheck> baseline_check;
  bool stopped = false;  ///< should_stop() ended the run early; nothing was written
  bool gate_passed = false;
  std::string gate_message;
  double wall_seconds = 0.0;
};

[[nodiscard]] std::filesystem::path checkpoint_path(const std::filesystem::path& model);

/// Trains every level and, if the gate passes, writes the model file and its metrics. Tuned levels
/// that `config` has not resolved yet are resolved first (resolve_levels on the training split).
GaTrainingResult train_ga(const GaTrainingConfig& config, const GaRunOptions& options,
                          const GaObserver& observer = {});

/// The model spec of trained levels.
[[nodiscard]] GaFuzzyImmSpec spec_from(const GaTrainingConfig& config,
                                       const std::vector<LevelResult>& levels);

/// "u0.01" for 0.01.
[[nodiscard]] std::string level_name(double maneuver_level);

}  // namespace imm::trainer::ga
