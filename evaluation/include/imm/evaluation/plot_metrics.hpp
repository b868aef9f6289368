// SPDX-License-Identifier: Apache-2.0
#pragma once
/// An experiment on recorded plots without truth: the filters are judged by how well they predict
/// the plots, with no error against a truth nobody has.
///
/// Per filter: the predictive log-likelihood per plot (1/N Σ log p(z | Z^(k−1)), higher is
/// better), the NIS averaged over tracks per scan against its two-sided 95 % χ² bounds, and the
/// innovation RMS √(1/N Σ ‖z − ẑ‖²) in the plot's coordinates; each learned filter against every
/// other with the 95 % paired-bootstrap interval over tracks. The headline (what the regression
/// gate compares) is FilterOutcome::plot_headline of the experiment's own filter.

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "imm/evaluation/evaluation_report.hpp"
#include "imm/evaluation/monte_carlo.hpp"

namespace imm::evaluation {

/// The plot-metric table of `filters` (ours against each other one): its markdown with the
/// definitions, the metrics.json entries, and the findings against `baselines` (ours not
/// predicting the plots better beyond the interval).
struct PlotTable {
  std::string text;
  nlohmann::json metrics;
  std::vector<std::string> findings;
};
[[nodiscard]] PlotTable plot_table(const std::vector<FilterOutcome>& filters,
                                   const std::string& ours,
                                   const std::vector<std::string>& baselines);

/// On recorded tracks that carry their truth (`data.recorded`), prints how well each filter
/// predicts the plots (plot_table, ours against the others) beside the experiment's errors.
/// Nothing for drawn tracks.
void print_recorded_prediction(const datasets::TrackSet& data,
                               const std::vector<FilterOutcome>& filters, const std::string& ours);
/// The same for an experiment whose errors come from its own loop: `outcomes` runs the filters
/// over `data` for their plot metrics, and only for recorded tracks.
void print_recorded_prediction(const datasets::TrackSet& data,
                               const std::function<std::vector<FilterOutcome>()>& outcomes,
                               const std::string& ours);

/// Prints the plot-metric tables of `filters` (ours against each other one), writes
/// metrics.json and headline.json in `out`, and returns the report's exit code: a finding
/// (exit 7) when `ours` does not beat a filter named in `baselines` in predictive NLL beyond the
/// interval, else 0.
int plots_only_report(const std::string& experiment, const std::vector<FilterOutcome>& filters,
                      const std::string& ours, const std::vector<std::string>& baselines,
                      const HeadlineRuns& evaluated, const std::filesystem::path& out,
                      const std::vector<ModelUse>& more_models = {});

}  // namespace imm::evaluation
