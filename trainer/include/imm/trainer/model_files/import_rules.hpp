// SPDX-License-Identifier: Apache-2.0
#pragma once
/// `imm-train import-rules`: writes published (or hand-made) fuzzy rule tables as a
/// "ga_fuzzy_imm" model file through the same writer the GA uses, so that they run in the same
/// runtime on the same noise as the learned tables. The CSV has the header
/// `level,c1,sigma1,c2,sigma2,w` and one row per rule; '#' lines are comments; levels keep the
/// order of their first row. Lines `#@ units = km`, `#@ sample_period = 1.0` and
/// `#@ measurement_sigma = 0.5` state what the tables were learned for: the regime the model is
/// stamped with (the GA config's, or `--regime`) must agree, or the import is refused naming the
/// field — a table learned at T = 1 s is not a model for T = 2 s. The IMM's transition and initial
/// probabilities come from the GA config's [filter] table.

#include <filesystem>
#include <optional>
#include <string>

#include "imm/filters/ga_fuzzy_imm.hpp"

namespace imm::trainer {

struct ImportRulesOptions {
  std::filesystem::path csv;
  std::filesystem::path config;                 ///< GA config (its [filter] table, its regime)
  std::optional<std::filesystem::path> regime;  ///< replaces the config's regime
  std::filesystem::path out;
};

/// Parses the CSV and checks its stated sample period, plot σ and units against `settings` and
/// `units`; std::runtime_error names the file and line of a bad row or the field that differs.
[[nodiscard]] GaFuzzyImmSpec read_rules_csv(const std::filesystem::path& csv,
                                            const AxisImmSettings& settings,
                                            const std::string& units);

/// Reads, validates and writes; returns the spec written.
GaFuzzyImmSpec import_rules(const ImportRulesOptions& options);

}  // namespace imm::trainer
