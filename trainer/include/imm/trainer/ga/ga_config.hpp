#pragma once
/// `configs/ga_fuzzy_imm.toml`: everything `imm-train ga` needs, one options struct per component,
/// keys one to one with fields (see the shipped config for every key and its meaning).

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "imm/filters/axis_filter.hpp"
#include "imm/trainer/ga/fuzzy_table_problem.hpp"
#include "imm/trainer/ga/genetic_algorithm.hpp"
#include "imm/trainer/ga/memetic.hpp"
#include "imm/trainer/ga/training_set.hpp"

namespace imm::trainer::ga {

struct TrainingOptions {
  std::vector<double> levels = {0.001, 0.01, 0.1};  ///< maneuver levels u_i = a_M (km/s²)
  double process_noise_sigma = 0.001;               ///< √q: truth's σ_w and eq. (15)
  TrainingProfile profile = TrainingProfile::kMixed;
  int trajectories = 12;            ///< training trajectories per level
  int validation_trajectories = 6;  ///< held out, per level
  int steps = 160;
  int min_segment = 10;  ///< mixed profile: segment lengths, scans
  int max_segment = 40;
  double initial_speed = 0.015;
};

struct GaTrainingConfig {
  std::uint64_t seed = 1;
  AxisImmSettings filter;
  TrainingOptions training;
  ProblemOptions fuzzy;  ///< maneuver_level and process_noise_sigma are set per level
  GaOptions ga;
  MemeticOptions memetic;
  double max_validation_error = 1.0;  ///< quality gate per level (eq. 17 units)

  std::string text;  ///< the config file's text (provenance)
  std::string name;  ///< the config file's name

  /// Throws InvalidParameter naming the key ("ga.lambda").
  void validate() const;
  /// Training or validation set for level i.
  [[nodiscard]] TrainingSetOptions training_set_options(std::size_t level, bool validation) const;
};

/// Loads and validates; unknown keys, wrong types and out-of-range values are ConfigErrors naming
/// the file and the key.
[[nodiscard]] GaTrainingConfig load_ga_config(const std::filesystem::path& path);

}  // namespace imm::trainer::ga
