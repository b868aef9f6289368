#pragma once
/// `imm-train import-rules`: writes published (or hand-made) fuzzy rule tables as a
/// "ga_fuzzy_imm" model file through the same writer the GA uses, so that they run in the same
/// runtime on the same noise as the learned tables. The CSV has the header
/// `level,c1,sigma1,c2,sigma2,w` and one row per rule; '#' lines are comments; levels keep the
/// order of their first row. The filter settings come from a GA config's [filter] table.

#include <filesystem>

#include "imm/filters/ga_fuzzy_imm.hpp"

namespace imm::trainer {

struct ImportRulesOptions {
  std::filesystem::path csv;
  std::filesystem::path config;  ///< GA config (its [filter] table)
  std::filesystem::path out;
};

/// Parses the CSV; std::runtime_error names the file and line of a bad row.
[[nodiscard]] GaFuzzyImmSpec read_rules_csv(const std::filesystem::path& csv,
                                            const AxisImmSettings& settings);

/// Reads, validates and writes; returns the spec written.
GaFuzzyImmSpec import_rules(const ImportRulesOptions& options);

}  // namespace imm::trainer
