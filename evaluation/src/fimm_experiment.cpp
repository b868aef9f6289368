// SPDX-License-Identifier: Apache-2.0
// `imm-eval fimm`: seed 002's experiment (Table 1, Fig. 6–8) on any regime with a range sensor.
// Per case of the regime (seed 002: the vehicle cut-in for R = 0.1², 0.5², 1², 2² I), on identical
// plots: the baseline IMM (h = identity), the FIMM (EKF through the learned TSK sensor model) and
// the FIMM with the iterated EKF update. Position MSE over tracks and scans (ξ and η errors squared
// and summed) with the FIMM − IMM difference and its 95 % paired-bootstrap interval, the position
// NEES of each filter (2 when consistent), and the share of FIMM steps that evaluated the sensor
// model outside the box it was fitted on (clamped there).
//
// The regime's sensor is the true one: a distortion, or the sensor a set of samples came from, so
// a model fitted with `imm-train tsk --data` is evaluated on its own sensor. A model fitted to
// another sensor is refused (check_model). The FIMM's own settings ([fimm]) come from the TSK
// config (--config); its T is the regime's.
//
// Gates, per case: the FIMM (EKF; --gate-on best: the better of EKF and IEKF) below the IMM beyond
// the uncertainty, and at most 5 % of its steps clamped.
//
// A recorded regime without truth (plots of a range sensor, z1 and z2, whose truth nobody has;
// the TSK model fitted to the sensor's calibration samples): the three filters are judged by how
// well they predict the test plots.

#include <Eigen/LU>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "imm/evaluation/consistency.hpp"
#include "imm/evaluation/evaluation_report.hpp"
#include "imm/evaluation/experiment.hpp"
#include "imm/evaluation/experiments.hpp"
#include "imm/evaluation/fimm_outcome.hpp"
#include "imm/evaluation/headline.hpp"
#include "imm/evaluation/monte_carlo.hpp"
#include "imm/evaluation/plot_metrics.hpp"
#include "imm/evaluation/report.hpp"
#include "imm/evaluation/uncertainty.hpp"
#include "imm/filters/fimm.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/tsk/tsk_trainer.hpp"

namespace imm::evaluation {
namespace {

// The columns of the tables, for metrics.json and report.md.
std::vector<MetricDefinition> fimm_definitions(const std::string& length) {
  return {
      {"IMM, FIMM (EKF), FIMM (IEKF)", length + "^2",
       "position MSE: ξ and η errors squared and summed, from scan 3 on, over tracks"},
      {"EKF − IMM, IEKF − IMM [95 %]", length + "^2",
       "MSE difference with its 95 % paired-bootstrap interval over tracks"},
      {"paper IMM, paper FIMM", length + "^2", "seed 002's Table 1"},
      {"NEES", "1", "mean position NEES (2 when consistent)"},
      {"clamped", "1", "share of FIMM steps whose estimate lay outside the sensor model's box"},
      {"flat, elsewhere", length + "^2",
       "MSE where the true sensor's range slope is flat, and elsewhere"},
  };
}

constexpr double kMaxClampedShare = 0.05;

// The IMM and the FIMM (EKF and IEKF) over recorded plots, for the plot metrics: with the
// regime's one plot noise (a recorded regime has one case).
std::vector<FilterOutcome> plot_outcomes(const datasets::Regime& regime, const FimmSpec& base,
                                         const std::shared_ptr<const TskSensorModel>& sensor_model,
                                         int iekf_iterations, const datasets::TrackSet& data) {
  FimmSpec spec = base;
  spec.measurement_covariance = regime.sensor.noise.covariance();
  FimmSpec iterated = spec;
  iterated.iterations = iekf_iterations;
  std::vector<FilterOutcome> outcomes;
  const auto evaluate = [&](const std::string& name, const FimmSpec& filter_spec,
                            const std::shared_ptr<const TskSensorModel>& model) {
    outcomes.push_back(run_monte_carlo(
        name, [&] { return std::make_unique<FimmFilter>(filter_spec, model); },
        filter_spec.track_options(), data));
  };
  evaluate("FIMM (EKF)", spec, sensor_model);
  evaluate("FIMM (IEKF)", iterated, sensor_model);
  evaluate("IMM", spec, nullptr);
  return outcomes;
}

// What the report collects over the cases.
struct Tables {
  std::vector<std::vector<std::string>> rows, split;
  std::vector<FilterConsistency> consistency;
  nlohmann::json metrics, details;
  Eigen::MatrixXd by_scan;
  std::vector<std::string> by_scan_names;
};

}  // namespace

FimmResult evaluate_fimm(const FimmOptions& options) {
  FimmResult r;
  const io::ModelFileReader reader(options.common.model_path(), io::kTskSensorKind);
  r.start("fimm", options.common, reader.provenance());
  r.gate_on = options.gate_on;
  const auto sensor_model = std::make_shared<const TskSensorModel>(io::read_tsk_sensor(r.model));
  const datasets::Regime& regime = r.regimes.evaluated.regime;
  check_model(
      {regime.sample_period, datasets::SensorKind::kRangeSensor, std::nullopt, std::nullopt},
      r.regimes, r.model);
  const trainer::tsk::TskTrainingConfig config = trainer::tsk::load_tsk_config(
      options.config, options.common.regime && options.common.regime->extension() != ".h5"
                          ? options.common.regime
                          : std::nullopt);
  FimmSpec base = config.fimm;
  base.sample_period = regime.sample_period;
  // The mode transitions the model was trained with (learned from the training tracks when its
  // config says "sojourns"): the FIMM and its IMM share them.
  const std::optional<FimmSpec> stored = io::read_fimm_settings(reader);
  if (stored &&
      std::abs(stored->sample_period - base.sample_period) <= 1e-12 * base.sample_period) {
    base.transition = stored->transition;
  }
  std::ostringstream settings;
  settings << "noise scale " << base.noise_scale << " (√q₁ = " << std::sqrt(base.process_noise(0))
           << ", √q₂ = " << std::sqrt(base.process_noise(1)) << " per step), IEKF "
           << config.iekf_iterations << " iterations, P(stay) " << base.transition(0, 0) << " / "
           << base.transition(1, 1)
           << (config.transitions_from_sojourns ? " (learned from the training tracks' sojourns)"
                                                : "");
  r.settings = settings.str();

  r.tracks = test_tracks(regime, options.common);
  const datasets::TrackSet& data = r.tracks;
  if (!data.has_truth || data.recorded) {
    r.filters = plot_outcomes(regime, base, sensor_model, config.iekf_iterations, data);
  }
  if (!data.has_truth) return r;  // judged by the plots' prediction in the report

  for (const CaseTracks& one_case : tracks_by_case(regime, data)) {
    const datasets::TrackSet& part = one_case.tracks;
    const datasets::SensorNoise& noise = regime.noise_of(one_case.index);
    FimmSpec spec = base;
    spec.measurement_covariance = noise.covariance();
    FimmSpec iterated = spec;
    iterated.iterations = config.iekf_iterations;
    const double variance = noise.sigma(0) * noise.sigma(0);
    FimmCase c;
    c.index = one_case.index;
    c.name = one_case.name;
    c.runs = static_cast<int>(part.tracks.size());
    c.measurement_variance = noise.covariance()(0, 0);
    c.imm = run_fimm_filter([&] { return std::make_unique<FimmFilter>(spec, nullptr); }, part,
                            regime.sensor, variance, spec.acceleration_variance);
    c.fimm = run_fimm_filter([&] { return std::make_unique<FimmFilter>(spec, sensor_model); }, part,
                             regime.sensor, variance, spec.acceleration_variance);
    c.iekf = run_fimm_filter([&] { return std::make_unique<FimmFilter>(iterated, sensor_model); },
                             part, regime.sensor, variance, spec.acceleration_variance);
    c.fimm_minus_imm = paired_difference(c.runs, c.fimm.statistic(), c.imm.statistic());
    c.iekf_minus_imm = paired_difference(c.runs, c.iekf.statistic(), c.imm.statistic());
    const bool best = options.gate_on == "best";
    const Difference& gated = best && c.iekf.mse < c.fimm.mse ? c.iekf_minus_imm : c.fimm_minus_imm;
    if (!gated.below()) {
      r.failures.push_back(c.name + ": " + (best ? "the better FIMM" : "the FIMM (EKF)") +
                           " is not below the IMM beyond the uncertainty (" + gated.text(3) +
                           " m²)");
    }
    if (c.fimm.clamped > kMaxClampedShare) {
      r.failures.push_back(c.name + ": " + cell(100.0 * c.fimm.clamped, 1) +
                           " % of the FIMM's steps evaluate the sensor model outside its box "
                           "(at most " +
                           cell(100.0 * kMaxClampedShare, 0) + " %)");
    }
    r.cases.push_back(std::move(c));
  }

  // The fitted sensor against the true one along the road (ξ = 0) and at the start's lateral
  // offset, over the model's box.
  const int points = 200;
  const Eigen::Vector2d lower = sensor_model->input_lower(), upper = sensor_model->input_upper();
  const double lane = data.tracks.front().truth(0, 0);
  r.sensor_curve.resize(points, 5);
  for (int i = 0; i < points; ++i) {
    const double eta = lower(1) + (upper(1) - lower(1)) * i / (points - 1.0);
    const Eigen::Vector2d on_road = regime.sensor.response({0.0, eta});
    const Eigen::Vector2d in_lane = regime.sensor.response({lane, eta});
    r.sensor_curve.row(i) << eta, on_road(1), sensor_model->evaluate({0.0, eta}).value(1),
        in_lane(0), sensor_model->evaluate({lane, eta}).value(0);
  }
  return r;
}

namespace {

// One case's rows of the tables, metrics and details; its path series and plot in `out`.
bool report_case(const FimmCase& c, const FimmResult& r, const std::filesystem::path& out,
                 Tables& tables) {
  const int steps = r.tracks.scans;
  const FimmOutcome& imm = c.imm;
  const FimmOutcome& fimm = c.fimm;
  const FimmOutcome& iekf = c.iekf;
  const Difference& d_fimm = c.fimm_minus_imm;
  const Difference& d_iekf = c.iekf_minus_imm;
  const auto* paper_imm = r.regimes.evaluated.find("IMM", c.name, "position_mse");
  const auto* paper_fimm = r.regimes.evaluated.find("FIMM (EKF)", c.name, "position_mse");
  tables.rows.push_back(
      {c.name, cell(imm.mse, 4), cell(fimm.mse, 4), cell(iekf.mse, 4), d_fimm.text(3),
       d_iekf.text(3), paper_imm ? cell(paper_imm->value, 4) : "–",
       paper_fimm ? cell(paper_fimm->value, 4) : "–", cell(imm.nees, 2), cell(fimm.nees, 2),
       cell(iekf.nees, 2), cell(100.0 * fimm.clamped, 1) + " %"});
  tables.consistency.push_back({c.name + ": IMM", imm.position_nees, imm.nis});
  tables.consistency.push_back({c.name + ": FIMM (EKF)", fimm.position_nees, fimm.nis});
  tables.consistency.push_back({c.name + ": FIMM (IEKF)", iekf.position_nees, iekf.nis});
  tables.split.push_back({c.name, cell(imm.mse_flat, 4), cell(fimm.mse_flat, 4),
                          cell(iekf.mse_flat, 4), cell(imm.mse_steep, 4), cell(fimm.mse_steep, 4),
                          cell(iekf.mse_steep, 4)});
  tables.metrics["rows"].push_back(
      {{"case", c.name},
       {"R", c.measurement_variance},
       {"imm_mse", imm.mse},
       {"fimm_mse", fimm.mse},
       {"fimm_iekf_mse", iekf.mse},
       {"fimm_minus_imm", {d_fimm.estimate, d_fimm.lower, d_fimm.upper}},
       {"iekf_minus_imm", {d_iekf.estimate, d_iekf.lower, d_iekf.upper}},
       {"fimm_clamped_share", fimm.clamped}});
  tables.details["rows"].push_back(
      {{"case", c.name},
       {"imm_nees", imm.nees},
       {"fimm_nees", fimm.nees},
       {"fimm_iekf_nees", iekf.nees},
       {"imm_nis", imm.nis.average},
       {"fimm_nis", fimm.nis.average},
       {"fimm_iekf_nis", iekf.nis.average},
       {"fimm_clamped_share", fimm.clamped},
       {"fimm_iekf_clamped_share", iekf.clamped},
       {"mse_flat", {{"imm", imm.mse_flat}, {"fimm", fimm.mse_flat}, {"fimm_iekf", iekf.mse_flat}}},
       {"mse_steep",
        {{"imm", imm.mse_steep}, {"fimm", fimm.mse_steep}, {"fimm_iekf", iekf.mse_steep}}},
       {"failed_steps", imm.failed_steps + fimm.failed_steps + iekf.failed_steps}});
  // Run 0's path, and the MSE per scan.
  const std::string stem = "case" + std::to_string(c.index);
  const datasets::Track* first = nullptr;
  for (const datasets::Track& track : r.tracks.tracks) {
    if (track.case_index == c.index) {
      first = &track;
      break;
    }
  }
  Eigen::MatrixXd path(steps, 8);
  path << first->truth.col(0), first->truth.col(3), first->plots, imm.first_run, fimm.first_run;
  write_series_csv(out / (stem + "_path.csv"),
                   {"truth_xi", "truth", "plots_xi", "plots", "IMM_xi", "IMM", "FIMM_xi", "FIMM"},
                   path);
  tables.by_scan.conservativeResize(steps, tables.by_scan.cols() + 3);
  tables.by_scan.rightCols(3) << imm.scan_mse, fimm.scan_mse, iekf.scan_mse;
  tables.by_scan_names.insert(tables.by_scan_names.end(),
                              {"IMM_" + stem, "FIMM_" + stem, "IEKF_" + stem});
  return plot_series({out / (stem + "_path.png"),
                      c.name + ", track 0 (seed 002 Fig. 6-8)",
                      "xi (m)",
                      "eta (m)",
                      out / (stem + "_path.csv"),
                      {"plots", "truth", "IMM", "FIMM"},
                      {"plots_xi", "truth_xi", "IMM_xi", "FIMM_xi"},
                      "points"});
}

}  // namespace

int report_fimm(const FimmResult& r, const FimmOptions& options) {
  const datasets::Regime& regime = r.regimes.evaluated.regime;
  const datasets::TrackSet& data = r.tracks;
  const std::filesystem::path& out = options.common.out;
  if (!data.has_truth) {  // recorded plots without truth: judged by their prediction
    std::cout << "fimm: " << r.regimes.describe() << "\n  test split: " << r.runs() << " tracks x "
              << data.scans << " scans\n\n";
    return plots_only_report("fimm", r.filters, "FIMM (EKF)", {"IMM"},
                             {"fimm", r.model, regime.name, regime.digest, r.seed, r.runs()}, out);
  }
  const int steps = data.scans;
  std::cout << "fimm: " << r.regimes.describe() << "\n  test split: " << data.tracks.size()
            << " tracks x " << steps << " scans, seed " << r.seed << "\n  FIMM: " << r.settings
            << "\n";
  std::filesystem::create_directories(out);
  Tables tables;
  tables.metrics["rows"] = nlohmann::json::array();
  tables.by_scan.resize(steps, 0);
  bool plotted = true;
  std::vector<HeadlineMetric> headline;  // FIMM (EKF) and (IEKF) MSE per case
  Eigen::Index offset = 0;
  const auto all_runs = static_cast<Eigen::Index>(r.runs());
  for (const FimmCase& c : r.cases) {
    headline.push_back(in_case(c.fimm.headline("fimm_mse " + c.name), offset, all_runs));
    headline.push_back(in_case(c.iekf.headline("fimm_iekf_mse " + c.name), offset, all_runs));
    // How far each run's covariance is from its errors: a less consistent candidate is held back.
    headline.push_back(in_case(nees_log_ratio_metric("fimm_position_nees_log_ratio " + c.name,
                                                     c.fimm.run_position_nees, 2),
                               offset, all_runs));
    headline.push_back(in_case(nees_log_ratio_metric("fimm_iekf_position_nees_log_ratio " + c.name,
                                                     c.iekf.run_position_nees, 2),
                               offset, all_runs));
    offset += c.runs;
    plotted &= report_case(c, r, out, tables);
  }
  std::cout << "\nPosition MSE (m², ξ and η errors squared and summed, scans 3 on, over tracks), "
               "the FIMM − IMM difference [95 %], the paper's, position NEES (2 when consistent) "
               "and the share of FIMM steps clamped to the model's box:\n\n"
            << markdown_table({"case", "IMM", "FIMM (EKF)", "FIMM (IEKF)", "EKF − IMM [95 %]",
                               "IEKF − IMM [95 %]", "paper IMM", "paper FIMM", "NEES IMM",
                               "NEES FIMM", "NEES IEKF", "clamped"},
                              tables.rows)
            << "\nPosition MSE where the true sensor is flat in range (dη_m/dη < " << kFlatSlope
            << ") and elsewhere:\n\n"
            << markdown_table({"case", "IMM flat", "FIMM flat", "IEKF flat", "IMM elsewhere",
                               "FIMM elsewhere", "IEKF elsewhere"},
                              tables.split)
            << "\nConsistency per case (the NIS of the sensor's (z1, z2) plot; scans 3 on):\n\n"
            << consistency_table(tables.consistency);
  print_recorded_prediction(data, r.filters, "FIMM (EKF)");
  std::cout << "\nGates (" << (r.gate_on == "best" ? "the better FIMM" : "the FIMM (EKF)")
            << " below the IMM beyond the uncertainty; at most " << 100.0 * kMaxClampedShare
            << " % clamped): " << (r.failures.empty() ? "passed" : "FAILED") << '\n';
  for (const auto& failure : r.failures) std::cout << "  - " << failure << '\n';
  nlohmann::json& details = tables.details;
  details["runs"] = data.tracks.size();
  details["seed"] = r.seed;
  details["regime"] = {{"name", regime.name},
                       {"model_regime", r.regimes.trained.regime.name},
                       {"off_training", r.regimes.off_training()}};
  details["fimm"] = r.settings;
  const HeadlineRuns evaluated{"fimm",        r.model, regime.name,
                               regime.digest, r.seed,  static_cast<int>(all_runs)};
  write_metrics(out, evaluated, fimm_definitions(std::string(datasets::to_string(regime.units))),
                tables.metrics);
  trainer::write_json_atomically(out / "details.json", details);
  write_headline(out, evaluated, headline);
  write_series_csv(out / "mse_by_scan.csv", tables.by_scan_names, tables.by_scan);
  write_series_csv(out / "sensor_model.csv",
                   {"eta", "true_eta_m", "model_z2", "true_xi_m_lane", "model_z1_lane"},
                   r.sensor_curve);
  plotted &= plot_series({out / "sensor_model.png",
                          "Sensor: distorted range along the road, truth vs TSK model",
                          "eta (m)",
                          "m",
                          out / "sensor_model.csv",
                          {"true_eta_m", "model_z2", "true_xi_m_lane", "model_z1_lane"},
                          {"eta", "eta", "eta", "eta"}});
  return finish_report(out, plotted, r.failures, /*failures_printed=*/true);
}

int run_fimm(const FimmOptions& options) { return report_fimm(evaluate_fimm(options), options); }

}  // namespace imm::evaluation
