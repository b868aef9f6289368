// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Model files of kind "ga_fuzzy_imm": the fuzzy rule tables of a GA-fuzzy IMM (seed 000).
///
///   /ga_fuzzy_imm              \@sample_period > 0, \@measurement_sigma > 0, \@transition_stay,
///                              \@initial_first_probability, \@level_count (1–8)
///   /ga_fuzzy_imm/level`<i>`     \@name, \@maneuver_level ≥ 0 (km/s² in seed 000), and any
///   per-level
///                              training metrics (\@fitness, \@error, \@rules, \@generations, …)
///   /ga_fuzzy_imm/level`<i>`/rules   n × 5 (n = 1–50), columns c1, sigma1, c2, sigma2, w
///                              (residuals in measurement units, w in (unit/s²)²; σ > 0, w ≥ 0)

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "imm/filters/ga_fuzzy_imm.hpp"
#include "imm/io/model_file.hpp"
#include "imm/runtime_export.hpp"

namespace imm::io {

/// The model_kind of GA-fuzzy IMM model files.
inline constexpr std::string_view kGaFuzzyImmKind = "ga_fuzzy_imm";

/// A training metric stored on a level's group: a real with its units, or a count.
struct IMM_RUNTIME_EXPORT LevelMetric {
  /// The attribute's name on the level's group.
  std::string name;
  /// A real (with `units`) or an integer count.
  Attribute value;
  std::string units = "1";  ///< of a real value
};

/// Writes the spec; `level_metrics[i]` (optional) are stored on level i's group.
IMM_RUNTIME_EXPORT void write_ga_fuzzy_imm(
    ModelFileWriter& writer, const GaFuzzyImmSpec& spec,
    const std::vector<std::vector<LevelMetric>>& level_metrics = {});

/// Reads and validates a GA-fuzzy IMM model; FileError names the file and the field.
[[nodiscard]] IMM_RUNTIME_EXPORT GaFuzzyImmSpec read_ga_fuzzy_imm(const ModelFileReader& reader);
/// Opens the file and reads it as read_ga_fuzzy_imm(const ModelFileReader&).
[[nodiscard]] IMM_RUNTIME_EXPORT GaFuzzyImmSpec
read_ga_fuzzy_imm(const std::filesystem::path& path);

/// The rule table as an n × 5 matrix (c1, σ1, c2, σ2, w) and back (validated).
[[nodiscard]] IMM_RUNTIME_EXPORT Eigen::MatrixXd rules_matrix(const FuzzyRuleTable& table);
/// Throws std::invalid_argument for a matrix that is not n × 5 or an invalid rule.
[[nodiscard]] IMM_RUNTIME_EXPORT FuzzyRuleTable table_from_matrix(const Eigen::MatrixXd& rules);

}  // namespace imm::io
