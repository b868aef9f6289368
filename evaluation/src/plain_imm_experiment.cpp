// SPDX-License-Identifier: Apache-2.0
// `imm-eval plain-imm`: a plain IMM model file (by default the three-level CV IMM of
// configs/track/cv3_imm.toml) on a regime's test tracks, against each of its modes run alone as a
// single Kalman filter, on identical plots. Metrics: seed 000's normalized errors ζ_p, ζ_v
// (normalized_errors.hpp) and RMSEs, with the IMM's gain over each mode and its paired-bootstrap
// interval. The regime is --regime, else the one the model was trained for (a regime's tuned
// CV/CA/CT IMM); a plain IMM written from a TOML records none and takes
// configs/regimes/paper/ga_imm_table3.toml (the seed-000 scenario).
//
// A plain IMM with learned noise schedules (`imm-train schedule`) is evaluated on its own regime
// (or --regime) and also against CT-IMM-tuned, the regime's CV/CA/CT IMM its schedules were
// learned on (classical_bar.hpp; --classical for the shipped file). Gate: not worse than it in
// ζ_p or ζ_v beyond the 95 % interval; not beating it is a finding.

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "imm/datasets/dataset_file.hpp"
#include "imm/evaluation/classical_bar.hpp"
#include "imm/evaluation/evaluation_report.hpp"
#include "imm/evaluation/experiment.hpp"
#include "imm/evaluation/experiments.hpp"
#include "imm/evaluation/headline.hpp"
#include "imm/evaluation/monte_carlo.hpp"
#include "imm/evaluation/plot_metrics.hpp"
#include "imm/evaluation/report.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/tracking/tracker.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::evaluation {
namespace {

// The IMM's mode j as a filter of its own.
PlainImmSpec single_mode(const PlainImmSpec& spec, std::size_t j) {
  PlainImmSpec single = spec;
  single.modes = {spec.modes[j]};
  single.transition = Eigen::MatrixXd::Ones(1, 1);
  single.initial_probabilities = Eigen::VectorXd::Ones(1);
  if (single.initialization.method == InitializationMethod::kExplicit &&
      single.mixing_dimension() != spec.mixing_dimension()) {
    // A mode alone lives in its own space (CV in 4 states, CT in 5, …): keep its part of the
    // explicit prior, entry by entry by name.
    const auto full = state_variable_names(spec.mixing_dimension());
    const auto own = state_variable_names(single.mixing_dimension());
    std::vector<Eigen::Index> indices;
    indices.reserve(own.size());
    for (const std::string& name : own) {
      indices.push_back(std::find(full.begin(), full.end(), name) - full.begin());
    }
    const auto n = static_cast<Eigen::Index>(own.size());
    Eigen::VectorXd state(n);
    Eigen::MatrixXd covariance(n, n);
    for (Eigen::Index a = 0; a < n; ++a) {
      state(a) = spec.initialization.state(indices[static_cast<std::size_t>(a)]);
      for (Eigen::Index b = 0; b < n; ++b) {
        covariance(a, b) = spec.initialization.covariance(indices[static_cast<std::size_t>(a)],
                                                          indices[static_cast<std::size_t>(b)]);
      }
    }
    single.initialization.state = state;
    single.initialization.covariance = covariance;
  }
  return single;
}

// Whether the file is a scheduled IMM written by `imm-train schedule` (its schedule on or off).
bool learned_schedule(const io::Provenance& provenance) {
  const auto it = provenance.training_metrics.find("noise_schedule");
  return it != provenance.training_metrics.end() && it->second == 1.0;
}

// The gate of a scheduled IMM against the bar's comparison: not worse in either criterion.
std::vector<std::string> schedule_gate(const BarComparison& versus_bar) {
  std::vector<std::string> failures;
  for (std::size_t k = 0; k < 2; ++k) {
    const Difference& d = versus_bar.differences[k];
    if (d.lower > 0.0) {
      failures.push_back(versus_bar.criteria[k] + " above " + std::string(kClassicalBarName) +
                         "'s by " + cell(d.estimate) + " [" + cell(d.lower) + ", " + cell(d.upper) +
                         "]");
    }
  }
  return failures;
}

}  // namespace

PlainImmResult evaluate_plain_imm(const PlainImmOptions& options) {
  PlainImmResult r;
  r.start("plain-imm", options.common);
  const io::ModelFileReader reader(r.model, io::kPlainImmKind);
  const PlainImmSpec spec = io::read_plain_imm(reader);
  r.scheduled = learned_schedule(reader.provenance()) && options.data.empty();
  datasets::TrackSet& data = r.tracks;
  r.length = "the data set's length unit";
  std::string units;  // the tracks' length unit ("" where a stored set does not say)
  if (r.scheduled) {
    r.regimes = evaluation_regimes(options.common, reader.provenance(), r.model);
    const datasets::Regime& regime = r.regimes.evaluated.regime;
    data = test_tracks(regime, options.common);
    r.length = units = std::string(datasets::to_string(regime.units));
    r.source = r.regimes.describe() + ", test split, seed " + std::to_string(options.common.seed);
  } else if (!options.data.empty()) {
    datasets::TrackSetFile stored = datasets::read_track_set(options.data);
    data = std::move(stored.set);
    units = stored.units;
    r.source =
        options.data + " (regime " + data.regime + ", sha256 " + stored.digest.substr(0, 16) + ")";
  } else {
    // --regime; else the regime the model was trained for (`imm-train baseline`); a plain IMM
    // frozen from a TOML records none and takes the seed-000 scenario.
    const datasets::RegimeFile regime = load_regime_option(options.common.regime.value_or(
        reader.provenance().regime_toml.empty()
            ? std::filesystem::path("configs/regimes/paper/ga_imm_table3.toml")
            : r.model));
    data = test_tracks(regime.regime, options.common);
    r.length = units = std::string(datasets::to_string(regime.regime.units));
    r.source =
        "regime " + regime.regime.name + " test split, seed " + std::to_string(options.common.seed);
  }
  // A model's lengths read in another unit would be 1000 times off (R, Q, the gate), silently.
  const std::string& model_units = reader.provenance().length_unit;
  if (!model_units.empty() && !units.empty() && model_units != units) {
    throw std::runtime_error("model " + r.model.string() + ": length_unit: the model works in " +
                             model_units + ", the tracks (" + r.source + ") in " + units);
  }
  if (std::abs(data.sample_period - spec.sample_period) > 1e-12 * spec.sample_period) {
    throw std::runtime_error("model " + r.model.string() + ": sample_period " +
                             std::to_string(spec.sample_period) + " s differs from the tracks' " +
                             std::to_string(data.sample_period) + " s");
  }
  auto evaluate = [&](const std::string& name, const PlainImmSpec& s) {
    r.filters.push_back(run_monte_carlo(
        name, [&] { return make_plain_imm_filter(s); }, s.track_options(), data));
  };
  evaluate(r.model.stem().string(), spec);
  for (std::size_t j = 0; j < spec.modes.size() && spec.modes.size() > 1; ++j) {
    evaluate("KF " + spec.modes[j].name, single_mode(spec, j));
  }
  if (!data.has_truth) return r;  // judged by the plots' prediction in the report

  const FilterOutcome& imm = r.filters.front();
  for (std::size_t f = 1; f < r.filters.size(); ++f) {
    r.imm_minus[r.filters[f].name] = {
        paired_difference(r.runs(), imm.zeta_p_statistic(), r.filters[f].zeta_p_statistic()),
        paired_difference(r.runs(), imm.zeta_v_statistic(), r.filters[f].zeta_v_statistic())};
  }
  if (r.scheduled) {
    r.versus_bar = compare_with_bar(
        imm.name, [&] { return make_plain_imm_filter(spec); }, spec.track_options(),
        r.regimes.trained.regime, data, r.regimes.evaluated.regime.sensor.position,
        options.common.classical);
    if (r.versus_bar) {
      if (r.versus_bar->verdict != "beats") r.findings.push_back(r.versus_bar->summary);
      r.failures = schedule_gate(*r.versus_bar);
    }
    if (learned_part_off(reader.provenance())) {
      r.findings.push_back(imm.name +
                           ": the trainer switched its schedules off (the file is the tuned "
                           "CV/CA/CT IMM itself)");
    }
  }
  return r;
}

int report_plain_imm(const PlainImmResult& r, const PlainImmOptions& options) {
  const datasets::TrackSet& data = r.tracks;
  const std::vector<FilterOutcome>& filters = r.filters;
  const int runs = r.runs();
  const std::filesystem::path& out = options.common.out;
  if (!data.has_truth) {  // recorded plots without truth: judged by their prediction
    std::cout << "plain-imm: " << r.source << ", " << runs << " tracks x " << data.scans
              << " scans\n\n";
    std::vector<std::string> modes;
    for (std::size_t f = 1; f < filters.size(); ++f) modes.push_back(filters[f].name);
    return plots_only_report("plain-imm", filters, filters.front().name, modes,
                             {"plain-imm", r.model, data.regime, data.digest(), data.seed, runs},
                             out);
  }
  std::vector<std::vector<std::string>> rows;
  for (const auto& f : filters) {
    const auto v = r.imm_minus.find(f.name);
    const bool compared = v != r.imm_minus.end();
    rows.push_back({f.name, std::to_string(f.modes), cell(f.zeta_p), cell(f.zeta_v),
                    compared ? v->second.zeta_p.text() : "–",
                    compared ? v->second.zeta_v.text() : "–", cell(f.position_rmse),
                    cell(f.velocity_rmse, 5)});
  }
  std::cout << "plain-imm: " << r.source << ", " << runs << " tracks x " << data.scans
            << " scans\n\n"
            << markdown_table({"filter", "modes", "ζ_p", "ζ_v", "IMM − this ζ_p [95 %]",
                               "IMM − this ζ_v [95 %]", "position RMSE", "velocity RMSE"},
                              rows)
            << "\nConsistency:\n\n"
            << consistency_table(filters);
  print_recorded_prediction(data, filters, filters.front().name);

  nlohmann::json versus_bar;
  if (r.versus_bar) {
    print_bar_comparison(*r.versus_bar);
    versus_bar = r.versus_bar->json();
  }
  if (r.scheduled) {
    std::cout << "\nGates (not worse than " << kClassicalBarName
              << ", the IMM the schedules were learned on, in ζ_p or ζ_v beyond the 95 % "
                 "interval): "
              << (r.failures.empty() ? "passed" : "FAILED") << '\n';
    for (const auto& failure : r.failures) std::cout << "  - " << failure << '\n';
    print_findings(r.findings);
  }

  std::filesystem::create_directories(out);
  nlohmann::json metrics;
  if (r.scheduled) metrics["versus_classical_bar"] = versus_bar;
  metrics["experiment"] = "plain-imm";
  metrics["data"] = r.source;
  metrics["runs"] = runs;
  metrics["steps"] = data.scans;
  metrics["dataset_digest"] = data.digest();
  for (const auto& f : filters) {
    metrics["rows"].push_back({{"filter", f.name},
                               {"modes", f.modes},
                               {"zeta_p", f.zeta_p},
                               {"zeta_v", f.zeta_v},
                               {"position_rmse", f.position_rmse},
                               {"velocity_rmse", f.velocity_rmse},
                               {"position_nees", f.position_consistency.average},
                               {"nis", f.nis_consistency.average},
                               {"rejected_steps", f.rejected_steps}});
  }
  const HeadlineRuns evaluated{"plain-imm", r.model, data.regime, data.digest(), data.seed, runs};
  write_metrics(out, evaluated, normalized_error_definitions(r.length, "IMM", true), metrics);
  write_headline(out, evaluated, filters.front().headline());
  bool plotted = write_error_series(filters, data.scans, out);
  plotted &= write_mode_probabilities(filters.front(), out, "mode_probabilities");
  if (r.scheduled) {
    trainer::write_json_atomically(out / "details.json",
                                   {{"versus_classical_bar", versus_bar},
                                    {"regime",
                                     {{"name", r.regimes.evaluated.regime.name},
                                      {"model_regime", r.regimes.trained.regime.name},
                                      {"off_training", r.regimes.off_training()}}},
                                    {"gate_failures", r.failures},
                                    {"findings", r.findings}});
    return finish_report(out, plotted, r.failures, /*failures_printed=*/true, r.findings);
  }
  std::cout << "\nwrote " << (out / "metrics.json").string() << ", CSV series"
            << (plotted ? " and PNG plots" : " (plots skipped: gnuplot unavailable or failed)")
            << " in " << out.string() << '\n';
  return 0;
}

int run_plain_imm(const PlainImmOptions& options) {
  return report_plain_imm(evaluate_plain_imm(options), options);
}

}  // namespace imm::evaluation
