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
#include <span>
#include <sstream>

#include "imm/datasets/random.hpp"
#include "imm/evaluation/consistency.hpp"
#include "imm/evaluation/evaluation_report.hpp"
#include "imm/evaluation/experiment.hpp"
#include "imm/evaluation/headline.hpp"
#include "imm/evaluation/monte_carlo.hpp"
#include "imm/evaluation/plot_metrics.hpp"
#include "imm/evaluation/report.hpp"
#include "imm/evaluation/uncertainty.hpp"
#include "imm/filters/fimm.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/trainer/normalized_errors.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/ranks.hpp"
#include "imm/trainer/tsk/tsk_trainer.hpp"

namespace imm::evaluation {
namespace {

// The columns of the tables, for metrics.json and report.md.
std::vector<MetricDefinition> definitions(const std::string& length) {
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

constexpr int kFirstScoredScan = 2;
constexpr double kMaxClampedShare = 0.05;
/// Below this range slope dη_m/dη the sensor counts as flat (the measured range changes by less
/// than half the true change).
constexpr double kFlatSlope = 0.5;

struct FimmOptions {
  CommonOptions common;
  std::filesystem::path config = "configs/tsk_range_sensor.toml";
  std::string gate_on = "ekf";
};

struct Score {
  double mse = 0.0, nees = 0.0;
  double mse_flat = 0.0, mse_steep = 0.0;  ///< where the true sensor is flat in range, elsewhere
  double clamped = 0.0;                    ///< share of steps outside the model's box
  long failed_steps = 0;
  Eigen::MatrixXd per_track;  ///< tracks × 2: Σ squared position error, samples
  Eigen::MatrixXd first_run;  ///< scans × 2: track 0's (ξ̂, η̂)
  Eigen::VectorXd scan_mse;   ///< per scan, over tracks
  /// Position NEES and NIS (of the sensor's (z1, z2)) against their χ² bounds for the runs.
  ConsistencySummary position_nees, nis;
  Eigen::MatrixXd run_position_nees;  ///< runs × scans (NaN where a scan has no sample)

  [[nodiscard]] HeadlineMetric headline(std::string name) const {
    return ratio_metric(std::move(name), per_track.col(0), per_track.col(1));
  }
  [[nodiscard]] Statistic statistic() const { return headline("mse").statistic(); }
};

// dη_m/dη of the true sensor at a position (central differences).
double range_slope(const datasets::Sensor& sensor, const Eigen::Vector2d& p) {
  const double h = 1e-4 * std::max(1.0, std::abs(p(1)));
  return (sensor.response({p(0), p(1) + h})(1) - sensor.response({p(0), p(1) - h})(1)) / (2.0 * h);
}

Score score(const std::function<std::unique_ptr<FimmFilter>()>& make,
            const datasets::TrackSet& data, const datasets::Sensor& sensor, double r,
            double acceleration_variance) {
  Score out;
  const Eigen::Index steps = data.scans;
  const double T = data.sample_period;
  const auto runs = static_cast<Eigen::Index>(data.tracks.size());
  out.per_track = Eigen::MatrixXd::Zero(runs, 2);
  Eigen::VectorXd scan_sum = Eigen::VectorXd::Zero(steps), scan_count = scan_sum;
  out.first_run = Eigen::MatrixXd::Constant(steps, 2, std::numeric_limits<double>::quiet_NaN());
  // One run's terms, per scan: counted, e², NEES, outside the sensor box, in the flat part, the
  // estimate (ξ̂, η̂), failed, NIS.
  constexpr std::ptrdiff_t kPerScan = 9;
  const auto width = static_cast<int>(steps * kPerScan);
  const std::vector<double> all =
      trainer::shared_items(static_cast<long>(runs), width, [&](long run, std::span<double> terms) {
        const datasets::Track& track = data.tracks[static_cast<std::size_t>(run)];
        const Eigen::MatrixXd& z = track.plots;
        std::unique_ptr<FimmFilter> filter = make();
        Eigen::VectorXd mean = Eigen::VectorXd::Zero(6);
        Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(6, 6);
        for (Eigen::Index axis = 0; axis < 2; ++axis) {
          const Eigen::Index p = 3 * axis;
          mean(p) = z(1, axis);
          mean(p + 1) = (z(1, axis) - z(0, axis)) / T;
          covariance.block<3, 3>(p, p) << r, r / T, 0.0, r / T, 2.0 * r / (T * T), 0.0, 0.0, 0.0,
              acceleration_variance;
        }
        filter->initialize(mean, covariance);
        for (Eigen::Index k = kFirstScoredScan; k < steps; ++k) {
          double* scan = terms.data() + k * kPerScan;
          if (filter->step(z.row(k).transpose()) != StepStatus::kOk) {
            scan[7] = 1.0;
            continue;
          }
          const GaussianState<6>& x = filter->estimate();
          const Eigen::Vector2d truth = datasets::position_at(track, k);
          const Eigen::Vector2d error(x.mean(0) - truth(0), x.mean(3) - truth(1));
          const trainer::StepConsistency consistency = trainer::step_consistency(*filter, truth);
          scan[0] = 1.0;
          scan[1] = error.squaredNorm();
          scan[2] = consistency.position_nees;
          scan[8] = consistency.nis;
          scan[3] = filter->outside_sensor_box() ? 1.0 : 0.0;
          scan[4] = range_slope(sensor, truth) < kFlatSlope ? 1.0 : 0.0;
          scan[5] = x.mean(0);
          scan[6] = x.mean(3);
        }
      });
  // The figures, summed in run order.
  double nees = 0.0, flat[2] = {}, steep[2] = {};
  long samples = 0, outside = 0;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Eigen::MatrixXd run_nees = Eigen::MatrixXd::Constant(runs, steps, nan), run_nis = run_nees;
  for (Eigen::Index run = 0; run < runs; ++run) {
    for (Eigen::Index k = kFirstScoredScan; k < steps; ++k) {
      const double* scan = all.data() + run * width + k * kPerScan;
      if (scan[7] != 0.0) ++out.failed_steps;
      if (scan[0] == 0.0) continue;
      const double e2 = scan[1];
      out.per_track.row(run) += Eigen::RowVector2d(e2, 1.0);
      scan_sum(k) += e2;
      scan_count(k) += 1.0;
      double* bucket = scan[4] != 0.0 ? flat : steep;
      bucket[0] += e2;
      bucket[1] += 1.0;
      nees += scan[2];
      run_nees(run, k) = scan[2];
      run_nis(run, k) = scan[8];
      outside += scan[3] != 0.0 ? 1 : 0;
      ++samples;
      if (run == 0) out.first_run.row(k) << scan[5], scan[6];
    }
  }
  const double n = std::max<double>(1.0, static_cast<double>(samples));
  out.position_nees = summarize_consistency(run_nees, 2);
  out.nis = summarize_consistency(run_nis, 2);
  out.run_position_nees = std::move(run_nees);
  out.mse = out.per_track.col(0).sum() / n;
  out.nees = nees / n;
  out.clamped = static_cast<double>(outside) / n;
  out.mse_flat = flat[1] > 0.0 ? flat[0] / flat[1] : nan;
  out.mse_steep = steep[1] > 0.0 ? steep[0] / steep[1] : nan;
  out.scan_mse = (scan_sum.array() / scan_count.array()).matrix();
  for (Eigen::Index k = 0; k < steps; ++k) {
    if (scan_count(k) == 0.0) out.scan_mse(k) = nan;
  }
  return out;
}

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

// A recorded regime without truth: the filters judged by how well they predict the test plots
// (plot_metrics.hpp).
int plots_only(const FimmOptions& options, const EvaluationRegimes& regimes,
               const std::filesystem::path& model_path, const FimmSpec& base,
               const std::shared_ptr<const TskSensorModel>& sensor_model, int iekf_iterations,
               const datasets::TrackSet& data) {
  const datasets::Regime& regime = regimes.evaluated.regime;
  const std::vector<FilterOutcome> outcomes =
      plot_outcomes(regime, base, sensor_model, iekf_iterations, data);
  const int runs = static_cast<int>(data.tracks.size());
  std::cout << "fimm: " << regimes.describe() << "\n  test split: " << runs << " tracks x "
            << data.scans << " scans\n\n";
  return plots_only_report(
      "fimm", outcomes, "FIMM (EKF)", {"IMM"},
      {"fimm", model_path, regime.name, regime.digest, options.common.seed, runs},
      options.common.out);
}

int run(const FimmOptions& options) {
  const std::filesystem::path model_path = options.common.model_path();
  const io::ModelFileReader reader(model_path, io::kTskSensorKind);
  const auto sensor_model = std::make_shared<const TskSensorModel>(io::read_tsk_sensor(model_path));
  const EvaluationRegimes regimes =
      evaluation_regimes(options.common, reader.provenance(), model_path);
  const datasets::Regime& regime = regimes.evaluated.regime;
  check_model(
      {regime.sample_period, datasets::SensorKind::kRangeSensor, std::nullopt, std::nullopt},
      regimes, model_path);
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

  const datasets::TrackSet data = test_tracks(regime, options.common);
  if (!data.has_truth) {
    return plots_only(options, regimes, model_path, base, sensor_model, config.iekf_iterations,
                      data);
  }
  const int steps = data.scans;
  std::cout << "fimm: " << regimes.describe() << "\n  test split: " << data.tracks.size()
            << " tracks x " << steps << " scans, seed " << options.common.seed
            << "\n  FIMM: " << settings.str() << "\n";
  const std::filesystem::path& out = options.common.out;
  std::filesystem::create_directories(out);
  nlohmann::json metrics, details;
  metrics["rows"] = nlohmann::json::array();
  std::vector<std::string> failures;
  std::vector<std::vector<std::string>> rows, split;
  bool plotted = true;
  Eigen::MatrixXd by_scan(steps, 0);
  std::vector<HeadlineMetric> headline;  // FIMM (EKF) and (IEKF) MSE per case
  Eigen::Index offset = 0;
  const auto all_runs = static_cast<Eigen::Index>(data.tracks.size());
  std::vector<std::string> by_scan_names;
  std::vector<FilterConsistency> consistency;
  for (const CaseTracks& one_case : tracks_by_case(regime, data)) {
    const datasets::TrackSet& part = one_case.tracks;
    const std::string& name = one_case.name;
    const datasets::SensorNoise& noise = regime.noise_of(one_case.index);
    FimmSpec spec = base;
    spec.measurement_covariance = noise.covariance();
    FimmSpec iterated = spec;
    iterated.iterations = config.iekf_iterations;
    const double r = noise.sigma(0) * noise.sigma(0);
    const Score imm = score([&] { return std::make_unique<FimmFilter>(spec, nullptr); }, part,
                            regime.sensor, r, spec.acceleration_variance);
    const Score fimm = score([&] { return std::make_unique<FimmFilter>(spec, sensor_model); }, part,
                             regime.sensor, r, spec.acceleration_variance);
    const Score iekf = score([&] { return std::make_unique<FimmFilter>(iterated, sensor_model); },
                             part, regime.sensor, r, spec.acceleration_variance);
    const int runs = static_cast<int>(part.tracks.size());
    headline.push_back(in_case(fimm.headline("fimm_mse " + name), offset, all_runs));
    headline.push_back(in_case(iekf.headline("fimm_iekf_mse " + name), offset, all_runs));
    // How far each run's covariance is from its errors: a less consistent candidate is held back.
    headline.push_back(in_case(
        nees_log_ratio_metric("fimm_position_nees_log_ratio " + name, fimm.run_position_nees, 2),
        offset, all_runs));
    headline.push_back(in_case(nees_log_ratio_metric("fimm_iekf_position_nees_log_ratio " + name,
                                                     iekf.run_position_nees, 2),
                               offset, all_runs));
    offset += runs;
    const Difference d_fimm = paired_difference(runs, fimm.statistic(), imm.statistic());
    const Difference d_iekf = paired_difference(runs, iekf.statistic(), imm.statistic());
    const auto* paper_imm = regimes.evaluated.find("IMM", name, "position_mse");
    const auto* paper_fimm = regimes.evaluated.find("FIMM (EKF)", name, "position_mse");
    rows.push_back({name, cell(imm.mse, 4), cell(fimm.mse, 4), cell(iekf.mse, 4), d_fimm.text(3),
                    d_iekf.text(3), paper_imm ? cell(paper_imm->value, 4) : "–",
                    paper_fimm ? cell(paper_fimm->value, 4) : "–", cell(imm.nees, 2),
                    cell(fimm.nees, 2), cell(iekf.nees, 2), cell(100.0 * fimm.clamped, 1) + " %"});
    consistency.push_back({name + ": IMM", imm.position_nees, imm.nis});
    consistency.push_back({name + ": FIMM (EKF)", fimm.position_nees, fimm.nis});
    consistency.push_back({name + ": FIMM (IEKF)", iekf.position_nees, iekf.nis});
    split.push_back({name, cell(imm.mse_flat, 4), cell(fimm.mse_flat, 4), cell(iekf.mse_flat, 4),
                     cell(imm.mse_steep, 4), cell(fimm.mse_steep, 4), cell(iekf.mse_steep, 4)});
    metrics["rows"].push_back({{"case", name},
                               {"R", noise.covariance()(0, 0)},
                               {"imm_mse", imm.mse},
                               {"fimm_mse", fimm.mse},
                               {"fimm_iekf_mse", iekf.mse},
                               {"fimm_minus_imm", {d_fimm.estimate, d_fimm.lower, d_fimm.upper}},
                               {"iekf_minus_imm", {d_iekf.estimate, d_iekf.lower, d_iekf.upper}},
                               {"fimm_clamped_share", fimm.clamped}});
    details["rows"].push_back(
        {{"case", name},
         {"imm_nees", imm.nees},
         {"fimm_nees", fimm.nees},
         {"fimm_iekf_nees", iekf.nees},
         {"imm_nis", imm.nis.average},
         {"fimm_nis", fimm.nis.average},
         {"fimm_iekf_nis", iekf.nis.average},
         {"fimm_clamped_share", fimm.clamped},
         {"fimm_iekf_clamped_share", iekf.clamped},
         {"mse_flat",
          {{"imm", imm.mse_flat}, {"fimm", fimm.mse_flat}, {"fimm_iekf", iekf.mse_flat}}},
         {"mse_steep",
          {{"imm", imm.mse_steep}, {"fimm", fimm.mse_steep}, {"fimm_iekf", iekf.mse_steep}}},
         {"failed_steps", imm.failed_steps + fimm.failed_steps + iekf.failed_steps}});
    const bool best = options.gate_on == "best";
    const Difference& gated = best && iekf.mse < fimm.mse ? d_iekf : d_fimm;
    if (!gated.below()) {
      failures.push_back(name + ": " + (best ? "the better FIMM" : "the FIMM (EKF)") +
                         " is not below the IMM beyond the uncertainty (" + gated.text(3) + " m²)");
    }
    if (fimm.clamped > kMaxClampedShare) {
      failures.push_back(name + ": " + cell(100.0 * fimm.clamped, 1) +
                         " % of the FIMM's steps evaluate the sensor model outside its box "
                         "(at most " +
                         cell(100.0 * kMaxClampedShare, 0) + " %)");
    }
    // Run 0's path, and the MSE per scan.
    const std::string stem = "case" + std::to_string(one_case.index);
    const datasets::Track& first = part.tracks.front();
    Eigen::MatrixXd path(steps, 8);
    path << first.truth.col(0), first.truth.col(3), first.plots, imm.first_run, fimm.first_run;
    write_series_csv(out / (stem + "_path.csv"),
                     {"truth_xi", "truth", "plots_xi", "plots", "IMM_xi", "IMM", "FIMM_xi", "FIMM"},
                     path);
    plotted &= plot_series({out / (stem + "_path.png"),
                            name + ", track 0 (seed 002 Fig. 6-8)",
                            "xi (m)",
                            "eta (m)",
                            out / (stem + "_path.csv"),
                            {"plots", "truth", "IMM", "FIMM"},
                            {"plots_xi", "truth_xi", "IMM_xi", "FIMM_xi"},
                            "points"});
    by_scan.conservativeResize(steps, by_scan.cols() + 3);
    by_scan.rightCols(3) << imm.scan_mse, fimm.scan_mse, iekf.scan_mse;
    by_scan_names.insert(by_scan_names.end(), {"IMM_" + stem, "FIMM_" + stem, "IEKF_" + stem});
  }
  std::cout << "\nPosition MSE (m², ξ and η errors squared and summed, scans 3 on, over tracks), "
               "the FIMM − IMM difference [95 %], the paper's, position NEES (2 when consistent) "
               "and the share of FIMM steps clamped to the model's box:\n\n"
            << markdown_table({"case", "IMM", "FIMM (EKF)", "FIMM (IEKF)", "EKF − IMM [95 %]",
                               "IEKF − IMM [95 %]", "paper IMM", "paper FIMM", "NEES IMM",
                               "NEES FIMM", "NEES IEKF", "clamped"},
                              rows)
            << "\nPosition MSE where the true sensor is flat in range (dη_m/dη < " << kFlatSlope
            << ") and elsewhere:\n\n"
            << markdown_table({"case", "IMM flat", "FIMM flat", "IEKF flat", "IMM elsewhere",
                               "FIMM elsewhere", "IEKF elsewhere"},
                              split)
            << "\nConsistency per case (the NIS of the sensor's (z1, z2) plot; scans 3 on):\n\n"
            << consistency_table(consistency);
  print_recorded_prediction(
      data, [&] { return plot_outcomes(regime, base, sensor_model, config.iekf_iterations, data); },
      "FIMM (EKF)");
  std::cout << "\nGates (" << (options.gate_on == "best" ? "the better FIMM" : "the FIMM (EKF)")
            << " below the IMM beyond the uncertainty; at most " << 100.0 * kMaxClampedShare
            << " % clamped): " << (failures.empty() ? "passed" : "FAILED") << '\n';
  for (const auto& failure : failures) std::cout << "  - " << failure << '\n';
  details["runs"] = data.tracks.size();
  details["seed"] = options.common.seed;
  details["regime"] = {{"name", regime.name},
                       {"model_regime", regimes.trained.regime.name},
                       {"off_training", regimes.off_training()}};
  details["fimm"] = settings.str();
  const HeadlineRuns evaluated{"fimm",        model_path,          regime.name,
                               regime.digest, options.common.seed, static_cast<int>(all_runs)};
  write_metrics(out, evaluated, definitions(std::string(datasets::to_string(regime.units))),
                metrics);
  trainer::write_json_atomically(out / "details.json", details);
  write_headline(out, evaluated, headline);
  write_series_csv(out / "mse_by_scan.csv", by_scan_names, by_scan);

  // The fitted sensor against the true one along the road (ξ = 0) and at the start's lateral
  // offset, over the model's box; and a sample of the calibration data.
  const int points = 200;
  const Eigen::Vector2d lower = sensor_model->input_lower(), upper = sensor_model->input_upper();
  const double lane = data.tracks.front().truth(0, 0);
  Eigen::MatrixXd curve(points, 5);
  for (int i = 0; i < points; ++i) {
    const double eta = lower(1) + (upper(1) - lower(1)) * i / (points - 1.0);
    const Eigen::Vector2d on_road = regime.sensor.response({0.0, eta});
    const Eigen::Vector2d in_lane = regime.sensor.response({lane, eta});
    curve.row(i) << eta, on_road(1), sensor_model->evaluate({0.0, eta}).value(1), in_lane(0),
        sensor_model->evaluate({lane, eta}).value(0);
  }
  write_series_csv(out / "sensor_model.csv",
                   {"eta", "true_eta_m", "model_z2", "true_xi_m_lane", "model_z1_lane"}, curve);
  plotted &= plot_series({out / "sensor_model.png",
                          "Sensor: distorted range along the road, truth vs TSK model",
                          "eta (m)",
                          "m",
                          out / "sensor_model.csv",
                          {"true_eta_m", "model_z2", "true_xi_m_lane", "model_z1_lane"},
                          {"eta", "eta", "eta", "eta"}});
  return finish_report(out, plotted, failures, /*failures_printed=*/true);
}

}  // namespace

void add_fimm_command(CLI::App& app, ExitCode& exit_code) {
  auto options = std::make_shared<FimmOptions>();
  auto* command = app.add_subcommand(
      "fimm", "seed 002 Table 1: FIMM (TSK sensor model, EKF and IEKF) vs the IMM");
  add_common_options(*command, options->common, "tsk_range_sensor", "reports/fimm");
  command->add_option("--config", options->config, "TSK config: the FIMM's settings ([fimm])");
  command
      ->add_option("--gate-on", options->gate_on,
                   "ekf: gate the FIMM (EKF); best: the better of EKF and IEKF")
      ->check(CLI::IsMember({"ekf", "best"}));
  command->callback([options, &exit_code] { exit_code = guarded([&] { return run(*options); }); });
}

}  // namespace imm::evaluation
