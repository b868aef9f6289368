// SPDX-License-Identifier: Apache-2.0
// `imm-eval plain-imm`: a plain IMM model file (by default the three-level CV IMM of
// configs/track/cv3_imm.toml) on a regime's test tracks, against each of its modes run alone as a
// single Kalman filter, on identical plots. Metrics: seed 000's normalized errors ζ_p, ζ_v
// (normalized_errors.hpp) and RMSEs, with the IMM's gain over each mode and its paired-bootstrap
// interval. A plain IMM written from a TOML is not trained: its regime is --regime, or
// configs/regimes/paper/ga_imm_table3.toml (the seed-000 scenario) by default.
//
// A plain IMM with learned noise schedules (`imm-train schedule`) is evaluated on its own regime
// (or --regime) and also against CT-IMM-tuned, the regime's CV/CA/CT IMM its schedules were
// learned on (classical_bar.hpp; --classical for the shipped file). Gate: not worse than it in
// ζ_p or ζ_v beyond the 95 % interval; not beating it is a finding.

#include <algorithm>
#include <iostream>
#include <nlohmann/json.hpp>

#include "imm/datasets/dataset_file.hpp"
#include "imm/evaluation/classical_bar.hpp"
#include "imm/evaluation/evaluation_report.hpp"
#include "imm/evaluation/experiment.hpp"
#include "imm/evaluation/headline.hpp"
#include "imm/evaluation/monte_carlo.hpp"
#include "imm/evaluation/plot_metrics.hpp"
#include "imm/evaluation/report.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/tracking/tracker.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::evaluation {
namespace {

struct PlainImmOptions {
  CommonOptions common;
  std::string data;  ///< a stored data-set file instead of drawing the test split
};

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

// The gate of a scheduled IMM against the bar's comparison (compare_with_classical_bar).
std::vector<std::string> schedule_gate(const nlohmann::json& versus_bar) {
  std::vector<std::string> failures;
  if (versus_bar.is_null()) return failures;
  for (const auto& [criterion, d] : versus_bar["differences"].items()) {
    if (d[1].get<double>() > 0.0) {
      failures.push_back(criterion + " above " + std::string(kClassicalBarName) + "'s by " +
                         cell(d[0].get<double>()) + " [" + cell(d[1].get<double>()) + ", " +
                         cell(d[2].get<double>()) + "]");
    }
  }
  return failures;
}

int run(const PlainImmOptions& options) {
  const std::filesystem::path model = options.common.model_path();
  const io::ModelFileReader reader(model, io::kPlainImmKind);
  const PlainImmSpec spec = io::read_plain_imm(reader);
  const bool scheduled = learned_schedule(reader.provenance());
  std::optional<EvaluationRegimes> regimes;
  datasets::TrackSet data;
  std::string source;
  std::string length = "the data set's length unit";
  if (scheduled && options.data.empty()) {
    regimes = evaluation_regimes(options.common, reader.provenance(), model);
    const datasets::Regime& regime = regimes->evaluated.regime;
    data = test_tracks(regime, options.common);
    length = std::string(datasets::to_string(regime.units));
    source = regimes->describe() + ", test split, seed " + std::to_string(options.common.seed);
  } else if (!options.data.empty()) {
    datasets::TrackSetFile stored = datasets::read_track_set(options.data);
    data = std::move(stored.set);
    source =
        options.data + " (regime " + data.regime + ", sha256 " + stored.digest.substr(0, 16) + ")";
  } else {
    const datasets::RegimeFile regime = load_regime_option(
        options.common.regime.value_or("configs/regimes/paper/ga_imm_table3.toml"));
    data = test_tracks(regime.regime, options.common);
    length = std::string(datasets::to_string(regime.regime.units));
    source =
        "regime " + regime.regime.name + " test split, seed " + std::to_string(options.common.seed);
  }
  if (std::abs(data.sample_period - spec.sample_period) > 1e-12 * spec.sample_period) {
    throw std::runtime_error("model " + model.string() + ": sample_period " +
                             std::to_string(spec.sample_period) + " s differs from the tracks' " +
                             std::to_string(data.sample_period) + " s");
  }
  std::vector<FilterOutcome> filters;
  auto evaluate = [&](const std::string& name, const PlainImmSpec& s) {
    filters.push_back(run_monte_carlo(
        name, [&] { return make_plain_imm_filter(s); }, s.track_options(), data));
  };
  evaluate(model.stem().string(), spec);
  for (std::size_t j = 0; j < spec.modes.size() && spec.modes.size() > 1; ++j) {
    evaluate("KF " + spec.modes[j].name, single_mode(spec, j));
  }

  const int runs = static_cast<int>(data.tracks.size());
  if (!data.has_truth) {  // recorded plots without truth: judged by their prediction
    std::cout << "plain-imm: " << source << ", " << runs << " tracks x " << data.scans
              << " scans\n\n";
    std::vector<std::string> modes;
    for (std::size_t f = 1; f < filters.size(); ++f) modes.push_back(filters[f].name);
    return plots_only_report("plain-imm", filters, filters.front().name, modes,
                             {"plain-imm", model, data.regime, data.digest(), data.seed, runs},
                             options.common.out);
  }
  std::vector<std::vector<std::string>> rows;
  for (const auto& f : filters) {
    std::string versus_p = "–", versus_v = "–";
    if (&f != &filters.front()) {
      versus_p =
          paired_difference(runs, filters.front().zeta_p_statistic(), f.zeta_p_statistic()).text();
      versus_v =
          paired_difference(runs, filters.front().zeta_v_statistic(), f.zeta_v_statistic()).text();
    }
    rows.push_back({f.name, std::to_string(f.modes), cell(f.zeta_p), cell(f.zeta_v), versus_p,
                    versus_v, cell(f.position_rmse), cell(f.velocity_rmse, 5)});
  }
  std::cout << "plain-imm: " << source << ", " << runs << " tracks x " << data.scans << " scans\n\n"
            << markdown_table({"filter", "modes", "ζ_p", "ζ_v", "IMM − this ζ_p [95 %]",
                               "IMM − this ζ_v [95 %]", "position RMSE", "velocity RMSE"},
                              rows)
            << "\nConsistency:\n\n"
            << consistency_table(filters);
  print_recorded_prediction(data, filters, filters.front().name);

  std::vector<std::string> findings, failures;
  nlohmann::json versus_bar;
  if (regimes) {
    versus_bar = compare_with_classical_bar(
        model.stem().string(), [&] { return make_plain_imm_filter(spec); }, spec.track_options(),
        regimes->trained.regime, data, regimes->evaluated.regime.sensor.position, findings,
        options.common.classical);
    failures = schedule_gate(versus_bar);
    std::cout << "\nGates (not worse than " << kClassicalBarName
              << ", the IMM the schedules were learned on, in ζ_p or ζ_v beyond the 95 % "
                 "interval): "
              << (failures.empty() ? "passed" : "FAILED") << '\n';
    for (const auto& failure : failures) std::cout << "  - " << failure << '\n';
    if (learned_part_off(reader.provenance())) {
      findings.push_back(model.stem().string() +
                         ": the trainer switched its schedules off (the file is the tuned "
                         "CV/CA/CT IMM itself)");
    }
    print_findings(findings);
  }

  const std::filesystem::path& out = options.common.out;
  std::filesystem::create_directories(out);
  nlohmann::json metrics;
  if (regimes) metrics["versus_classical_bar"] = versus_bar;
  metrics["experiment"] = "plain-imm";
  metrics["data"] = source;
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
  const HeadlineRuns evaluated{"plain-imm", model, data.regime, data.digest(), data.seed, runs};
  write_metrics(out, evaluated, normalized_error_definitions(length, "IMM", true), metrics);
  write_headline(out, evaluated, filters.front().headline());
  bool plotted = write_error_series(filters, data.scans, out);
  plotted &= write_mode_probabilities(filters.front(), out, "mode_probabilities");
  if (regimes) {
    trainer::write_json_atomically(out / "details.json",
                                   {{"versus_classical_bar", versus_bar},
                                    {"regime",
                                     {{"name", regimes->evaluated.regime.name},
                                      {"model_regime", regimes->trained.regime.name},
                                      {"off_training", regimes->off_training()}}},
                                    {"gate_failures", failures},
                                    {"findings", findings}});
    return finish_report(out, plotted, failures, /*failures_printed=*/true, findings);
  }
  std::cout << "\nwrote " << (out / "metrics.json").string() << ", CSV series"
            << (plotted ? " and PNG plots" : " (plots skipped: gnuplot unavailable or failed)")
            << " in " << out.string() << '\n';
  return 0;
}

}  // namespace

void add_plain_imm_command(CLI::App& app, ExitCode& exit_code) {
  auto options = std::make_shared<PlainImmOptions>();
  auto* command = app.add_subcommand(
      "plain-imm", "a plain IMM model on a regime's test tracks vs. its modes alone");
  add_common_options(*command, options->common, "cv3_imm", "reports/plain-imm");
  add_classical_option(*command, options->common);
  command->add_option("--data", options->data,
                      "evaluate a stored data-set file (imm-data tracks) instead");
  command->callback([options, &exit_code] { exit_code = guarded([&] { return run(*options); }); });
}

}  // namespace imm::evaluation
