// SPDX-License-Identifier: Apache-2.0
#pragma once
/// What every imm-eval report folder holds besides its CSV series and plots, in one shape for all
/// experiments:
///
/// - `metrics.json`:
///     {"format": "immtrain-evaluation", "format_version": 1, "experiment", "command",
///      "regime": {"name", "digest"}, "runs", "seed",
///      "models": [{"role", "file", "kind", "sha256", "trainer_version", "created_utc",
///                  "schema_version", "regime"}],
///      "definitions": [{"name", "unit", "definition"}],
///      "results": {…the experiment's own tables…}}
/// - `report.md`: the same header (command, regime, runs, seed, every model with its digest and
///   trainer version, the metric definitions with their units), then the tables and gates the
///   experiment printed — a report a person can read without the terminal it ran in.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <streambuf>
#include <string>
#include <vector>

#include "imm/evaluation/headline.hpp"

namespace imm::evaluation {

/// A metric's name as the tables print it, its unit ("1": dimensionless) and what it is.
struct MetricDefinition {
  std::string name;
  std::string unit;
  std::string definition;
};

/// A model file an evaluation used, and for what ("evaluated", "paper", …).
struct ModelUse {
  std::string role;
  std::filesystem::path file;
};

/// Writes `out`/metrics.json (atomically) in the shared shape: `runs` says what was evaluated (its
/// model is the "evaluated" one), `more_models` any other model file used, `results` the
/// experiment's tables. Remembers `out` for the report.md the command writes when it ends.
void write_metrics(const std::filesystem::path& out, const HeadlineRuns& runs,
                   const std::vector<MetricDefinition>& definitions, nlohmann::json results,
                   const std::vector<ModelUse>& more_models = {});

/// The model's provenance as metrics.json records it. Throws io::FileError for a bad file.
[[nodiscard]] nlohmann::json model_provenance(const ModelUse& use);

/// Records the command line and everything written to std::cout while it lives; on
/// finish(), writes report.md beside the metrics.json written meanwhile (if any).
class ReportRecorder {
 public:
  ReportRecorder(int argc, const char* const* argv);
  ~ReportRecorder();
  ReportRecorder(const ReportRecorder&) = delete;
  ReportRecorder& operator=(const ReportRecorder&) = delete;

  /// Writes report.md when an experiment wrote a metrics.json; returns its path or empty.
  std::filesystem::path finish();

 private:
  class Tee;
  std::unique_ptr<Tee> tee_;
  std::streambuf* original_ = nullptr;
};

/// ζ_p, ζ_v, the difference column "<reference> − this [95 %]" and, `with_rmse`, the RMSEs of
/// seed 000 §4 (normalized_errors.hpp), lengths in `length`: exactly the columns of the table.
[[nodiscard]] std::vector<MetricDefinition> normalized_error_definitions(
    const std::string& length, const std::string& reference, bool with_rmse);

/// The command line of this run ("imm-eval fimm --models models …"), for the reports.
[[nodiscard]] const std::string& command_line();

}  // namespace imm::evaluation
