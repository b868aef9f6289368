// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/plot_metrics.hpp"

#include <iostream>
#include <nlohmann/json.hpp>

#include "imm/evaluation/experiment.hpp"
#include "imm/evaluation/headline.hpp"
#include "imm/evaluation/report.hpp"
#include "imm/evaluation/uncertainty.hpp"
#include "imm/support/exit_codes.hpp"

namespace imm::evaluation {

PlotTable plot_table(const std::vector<FilterOutcome>& filters, const std::string& ours,
                     const std::vector<std::string>& baselines) {
  const FilterOutcome& own = find_filter(filters, ours);
  const std::vector<HeadlineMetric> own_metrics = own.plot_headline();
  const int runs = static_cast<int>(own_metrics[0].runs());
  std::vector<std::vector<std::string>> rows;
  PlotTable table;
  for (const FilterOutcome& f : filters) {
    const std::vector<HeadlineMetric> m = f.plot_headline();
    std::vector<std::string> row{
        f.name, cell(-m[0].value(), 3),
        f.nis_consistency.scans > 0 ? cell(f.nis_consistency.average, 2) : "–",
        cell(m[2].value(), 4)};
    row.push_back(f.nis_consistency.scans > 0 ? cell(100.0 * f.nis_consistency.inside, 1) + " %"
                                              : "–");
    nlohmann::json entry = {{"predictive_log_likelihood", -m[0].value()},
                            {"nis", f.nis_consistency.average},
                            {"nis_scans_inside", f.nis_consistency.inside},
                            {"nis_consistency", f.nis_consistency.verdict()},
                            {"innovation_rms", m[2].value()}};
    if (f.name == ours) {
      row.insert(row.end(), {"–", "–"});
    } else {
      // ours − this: a negative NLL difference means ours predicts the plots better.
      const Difference nll = paired_difference(runs, own_metrics[0].statistic(), m[0].statistic());
      const Difference rms = paired_difference(runs, own_metrics[2].statistic(), m[2].statistic());
      row.insert(row.end(), {nll.text(), rms.text()});
      entry["versus_ours"] = {{"predictive_nll", {nll.estimate, nll.lower, nll.upper}},
                              {"innovation_rms", {rms.estimate, rms.lower, rms.upper}}};
      if (std::find(baselines.begin(), baselines.end(), f.name) != baselines.end() &&
          !nll.below()) {
        table.findings.push_back(ours +
                                 (nll.above() ? " predicts the plots worse than "
                                              : " does not predict the plots better than ") +
                                 f.name + " beyond the uncertainty (predictive NLL per plot " +
                                 nll.text() + ")");
      }
    }
    rows.push_back(std::move(row));
    table.metrics[f.name] = entry;
  }
  table.text = markdown_table({"filter", "log-likelihood per plot", "NIS", "innovation RMS",
                               "NIS scans inside 95 %", ours + " − this NLL per plot [95 %]",
                               ours + " − this innovation RMS [95 %]"},
                              rows) +
               "\nlog-likelihood per plot: 1/N Σ log p(z | Z^(k−1)), the filter's predictive "
               "density of each plot (higher is better; the NLL is its negative). NIS: νᵀ S⁻¹ ν "
               "averaged over the tracks per scan and then over the scans (2 for a consistent "
               "filter). Innovation RMS: √(1/N Σ ‖z − ẑ‖²), in the plot's coordinates.\n" +
               std::string(kDifferenceConvention) + "\n";
  return table;
}

void print_recorded_prediction(const datasets::TrackSet& data,
                               const std::vector<FilterOutcome>& filters, const std::string& ours) {
  if (!data.recorded) return;
  std::cout << "\nThe recorded plots' prediction:\n\n" << plot_table(filters, ours, {}).text;
}

void print_recorded_prediction(const datasets::TrackSet& data,
                               const std::function<std::vector<FilterOutcome>()>& outcomes,
                               const std::string& ours) {
  if (data.recorded) print_recorded_prediction(data, outcomes(), ours);
}

int plots_only_report(const std::string& experiment, const std::vector<FilterOutcome>& filters,
                      const std::string& ours, const std::vector<std::string>& baselines,
                      const HeadlineRuns& evaluated, const std::filesystem::path& out,
                      const std::vector<ModelUse>& more_models) {
  const PlotTable table = plot_table(filters, ours, baselines);
  const std::vector<std::string>& findings = table.findings;
  const nlohmann::json& metrics = table.metrics;
  const FilterOutcome& own = find_filter(filters, ours);
  std::cout << experiment << ": the tracks have no truth; the filters are judged by how well they "
            << "predict the plots\n\n"
            << table.text << "\nConsistency (NIS):\n\n"
            << consistency_table(filters);
  print_findings(findings);
  std::filesystem::create_directories(out);
  const std::vector<MetricDefinition> definitions = {
      {"predictive_log_likelihood", "nats per plot",
       "1/N Σ log p(z | Z^(k−1)) over every update of every track"},
      {"nis", "", "νᵀ S⁻¹ ν averaged over the tracks per scan, then over the scans"},
      {"innovation_rms", "plot units", "√(1/N Σ ‖z − ẑ‖²)"}};
  write_metrics(out, evaluated, definitions, {{"truth", false}, {"filters", metrics}}, more_models);
  write_headline(out, evaluated, own.plot_headline());
  std::cout << "\nwrote metrics.json and headline.json in " << out.string() << '\n';
  return findings.empty() ? 0 : support::exit_code::kFindings;
}

}  // namespace imm::evaluation
