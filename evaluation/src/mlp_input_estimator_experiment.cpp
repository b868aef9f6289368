// SPDX-License-Identifier: Apache-2.0
// `imm-eval input-estimator`: seed 001's experiments (Tables 1 and 2) on any regime with
// Cartesian plots. The estimator is one axis: every axis of every test track is one run. On the
// same plots: the constant-velocity KF, the corrected KF (the network's acceleration fed to the
// primary KF, eq. 10), the constant-q IMM tuned on the model's training split (IMM-tuned: three
// noise levels and the stay probability, the search the GA trainer and the regime's baseline use)
// and, as a floor, the primary KF fed the true acceleration. Per case of the regime: the MSE of
// the innovation, the position and the velocity over every scan after the two-point start, the
// corrected − CV and corrected − IMM-tuned differences with their 95 % paired-bootstrap
// intervals, and the paper's figures where the regime file records them.
//
// Gate: the corrected KF beats the CV KF beyond the uncertainty in at least 90 % of the cells (the
// paper's claim). Findings: every case where it does not beat IMM-tuned in position and velocity.

#include <algorithm>
#include <array>
#include <cmath>
#include <iostream>
#include <limits>
#include <nlohmann/json.hpp>
#include <span>

#include "imm/datasets/axis_trajectory.hpp"
#include "imm/evaluation/classical_bar.hpp"
#include "imm/evaluation/consistency.hpp"
#include "imm/evaluation/evaluation_report.hpp"
#include "imm/evaluation/experiment.hpp"
#include "imm/evaluation/headline.hpp"
#include "imm/evaluation/monte_carlo.hpp"
#include "imm/evaluation/plot_metrics.hpp"
#include "imm/evaluation/report.hpp"
#include "imm/evaluation/uncertainty.hpp"
#include "imm/filters/axis_cv_imm.hpp"
#include "imm/filters/mlp_input_estimator.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/trainer/baseline_tuning.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/ranks.hpp"
#include "imm/trainer/regime_checks.hpp"

namespace imm::evaluation {
namespace {

// The columns of the tables, for metrics.json and report.md.
std::vector<MetricDefinition> definitions(const std::string& length) {
  return {
      {"innov CV, innov corrected", length + "^2",
       "MSE of the innovation of the CV KF and of the primary KF corrected by û"},
      {"pos CV, pos corrected", length + "^2", "position MSE of the two"},
      {"vel CV, vel corrected", "(" + length + "/s)^2", "velocity MSE of the two"},
      {"ratio", "1", "corrected / CV"},
      {"beats", "–",
       "whether the corrected KF is below the CV KF beyond the 95 % paired-bootstrap interval"},
      {"pos, true input (floor)", length + "^2", "the primary KF fed the true acceleration"},
  };
}

constexpr double kRequiredShare = 0.9;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr const char* kQuantity[3] = {"innovation", "position", "velocity"};

// "estimate [lower, upper]" of a difference of MSEs, in the tables' scientific notation.
std::string interval_text(const Difference& d) {
  return scientific(d.estimate) + " [" + scientific(d.lower) + ", " + scientific(d.upper) + "]";
}

struct CaseResult {
  std::string name;
  Eigen::MatrixXd cv, corrected, floor;  // runs × 3 (innovation, position, velocity MSE)
  Eigen::MatrixXd imm;                   // runs × 3: IMM-tuned (its innovation column unused)
  Eigen::VectorXd true_acceleration, mean_estimate;           // per scan (run 0; mean of runs)
  Eigen::VectorXd cv_position_rmse, corrected_position_rmse;  // per scan
  /// Axis runs × scans: position NEES and NIS (1-D) of the corrected KF and of IMM-tuned.
  std::array<std::vector<Eigen::RowVectorXd>, 4> consistency;
};

// Axis runs × scans of one of CaseResult::consistency's series.
Eigen::MatrixXd stacked(const std::vector<Eigen::RowVectorXd>& rows) {
  Eigen::MatrixXd values(static_cast<Eigen::Index>(rows.size()),
                         rows.empty() ? 0 : rows.front().size());
  for (std::size_t j = 0; j < rows.size(); ++j) values.row(static_cast<Eigen::Index>(j)) = rows[j];
  return values;
}

// The corrected KF's position and velocity MSE per case, over all runs in case order (a run of
// another case weighs nothing in a case's figure), and how far its covariance is from its errors
// (per axis run |ln ANEES| of the 1-D position NEES: a less consistent candidate is held back).
std::vector<HeadlineMetric> corrected_headline(const std::vector<CaseResult>& cases) {
  Eigen::Index runs = 0;
  for (const CaseResult& r : cases) runs += r.corrected.rows();
  std::vector<HeadlineMetric> headline;
  Eigen::Index offset = 0;
  for (const CaseResult& r : cases) {
    for (int q : {1, 2}) {
      headline.push_back(
          in_case(mean_metric(std::string(kQuantity[q]) + "_mse " + r.name, r.corrected.col(q)),
                  offset, runs));
    }
    headline.push_back(in_case(
        nees_log_ratio_metric("position_nees_log_ratio " + r.name, stacked(r.consistency[0]), 1),
        offset, runs));
    offset += r.corrected.rows();
  }
  return headline;
}

int run(const CommonOptions& options) {
  const std::filesystem::path model_path = options.model_path();
  const io::ModelFileReader reader(model_path, io::kMlpInputEstimatorKind);
  const MlpInputEstimatorModel model = io::read_mlp_input_estimator(model_path);
  const EvaluationRegimes regimes = evaluation_regimes(options, reader.provenance(), model_path);
  const CvKfSettings& settings = model.settings;
  check_model({settings.sample_period, datasets::SensorKind::kCartesian,
               std::sqrt(settings.measurement_variance), std::nullopt},
              regimes, model_path);
  const datasets::Regime& regime = regimes.evaluated.regime;
  const datasets::TrackSet data = test_tracks(regime, options);

  const double T = settings.sample_period;
  const double R = settings.measurement_variance;
  const auto motion = constant_velocity<1>(T, settings.process_noise);
  const Matrix<2, 1> G = cv_axis_input_gain(T);
  Matrix<1, 2> H;
  H << 1.0, 0.0;
  const SquareMatrix<1> R_matrix = SquareMatrix<1>::Constant(R);
  const int steps = data.scans;

  // The tuned classical filter, on the model's training split (never the test tracks).
  const datasets::Regime& own = regimes.trained.regime;
  AxisImmSettings imm_settings;
  imm_settings.sample_period = T;
  imm_settings.measurement_sigma = std::sqrt(R);
  const trainer::Tuned<AxisCvImmSpec> imm_tuned = trainer::tune_imm_baseline(
      imm_settings, {trainer::make_training_set(own, datasets::Split::kTraining)},
      trainer::acceleration_scale(own));

  // How well every filter predicts the plots (the judgement without truth, where the true-input
  // floor needs the truth and is left out; beside the errors on recorded tracks with truth).
  AxisCvImmSpec cv_kf;  // the CV KF: a one-mode IMM with the features' q
  cv_kf.settings = imm_settings;
  cv_kf.process_noise = {settings.process_noise};
  const auto plot_outcomes = [&] {
    const std::vector<std::pair<std::string, FilterFactory>> makers = {
        {"CV KF", [&] { return make_axis_cv_imm_filter(cv_kf); }},
        {"IMM-tuned", [&] { return make_axis_cv_imm_filter(imm_tuned.spec); }},
        {"corrected KF", [&] { return make_mlp_input_estimator_filter(model); }}};
    std::vector<FilterOutcome> outcomes;
    outcomes.reserve(makers.size());
    for (const auto& [name, make] : makers) {
      outcomes.push_back(run_monte_carlo(name, make, model.track_options(), data));
    }
    return outcomes;
  };
  if (!data.has_truth) {  // recorded plots without truth: judged by their prediction
    const std::vector<FilterOutcome> outcomes = plot_outcomes();
    const int runs = static_cast<int>(data.tracks.size());
    std::cout << "input-estimator: " << regimes.describe() << "\n  test split: " << runs
              << " tracks x " << data.scans << " scans; IMM-tuned on the training split of "
              << own.name << "\n\n";
    return plots_only_report(
        "input-estimator", outcomes, "corrected KF", {"CV KF", "IMM-tuned"},
        {"input-estimator", model_path, regime.name, regime.digest, options.seed, runs},
        options.out);
  }

  std::vector<CaseResult> cases(static_cast<std::size_t>(regime.case_count()));
  std::vector<std::vector<Eigen::RowVector3d>> cv_runs(cases.size()), corrected_runs(cases.size()),
      floor_runs(cases.size()), imm_runs(cases.size());
  std::vector<int> case_runs(cases.size(), 0);
  for (std::size_t c = 0; c < cases.size(); ++c) {
    cases[c].name = case_label(regime, static_cast<int>(c));
    cases[c].mean_estimate = Eigen::VectorXd::Zero(steps);
    cases[c].cv_position_rmse = Eigen::VectorXd::Zero(steps);
    cases[c].corrected_position_rmse = Eigen::VectorXd::Zero(steps);
  }
  // axis_trajectories gives each track's x then its y axis.
  const std::vector<datasets::AxisTrajectory> axes = datasets::axis_trajectories(data);
  // One axis run's terms: its mean squared innovation, position and velocity errors of the CV
  // filter, the corrected estimate, the known-input floor and IMM-tuned (4 × 3); per scan:
  // counted, the acceleration estimate, the CV and corrected squared position errors, then the
  // position NEES and the NIS of the corrected KF and of IMM-tuned (NaN where a filter rejected
  // the plot: each filter's figures are over the plots it used).
  constexpr std::ptrdiff_t kPerScan = 8;
  constexpr std::ptrdiff_t kRunTerms = 12;
  const auto width = static_cast<int>(kRunTerms + steps * kPerScan);
  const std::vector<double> all = trainer::shared_items(
      static_cast<long>(axes.size()), width, [&](long run, std::span<double> terms) {
        const datasets::AxisTrajectory& t = axes[static_cast<std::size_t>(run)];
        MlpInputEstimatorAxis axis(model, settings);
        ImmAxisFilter imm(build_axis_cv_imm(imm_tuned.spec));
        const GaussianState<2> start = datasets::two_point_start(t, T, R);
        axis.initialize(start);
        imm.initialize(start);
        GaussianState<2> known = start;  // the primary KF fed the true acceleration
        Eigen::RowVector3d cv = Eigen::RowVector3d::Zero(), corrected = cv, floor = cv, tuned = cv;
        int samples = 0, imm_samples = 0;
        auto add = [](Eigen::RowVector3d& sum, double nu, double dp, double dv) {
          sum += Eigen::RowVector3d(nu * nu, dp * dp, dv * dv);
        };
        // ν²/S and the position's e²/P (1-D NIS and NEES).
        auto consistency = [&t](double* out, const AxisFilter& scored, int k) {
          const GaussianState<2>& x = scored.estimate();
          out[0] = x.covariance(0, 0) > 0.0
                       ? std::pow(t.position(k) - x.mean(0), 2) / x.covariance(0, 0)
                       : kNaN;
          double nu = 0.0, variance = 0.0;
          out[1] = scored.innovation(nu, variance) && variance > 0.0 ? nu * nu / variance : kNaN;
        };
        for (int k = 2; k < steps; ++k) {
          double* scan = terms.data() + kRunTerms + k * kPerScan;
          std::fill_n(scan + 4, 4, kNaN);
          if (imm.step(t.measurement(k)) == StepStatus::kOk) {
            const auto& m = imm.estimate();
            add(tuned, 0.0, t.position(k) - m.mean(0), t.velocity(k) - m.mean(1));
            ++imm_samples;
            consistency(scan + 6, imm, k);
          }
          if (axis.step(t.measurement(k)) != StepStatus::kOk) continue;
          known = predict(known, motion.transition, motion.process_noise, G,
                          Vector<1>(t.acceleration_input(k - 1)));
          const auto known_report = update(known, Vector<1>(t.measurement(k)), H, R_matrix);
          const MlpInputEstimatorFilter& filter = axis.filter();
          const auto& e = filter.cv_estimate();
          const auto& p = filter.estimate();
          add(cv, filter.cv_innovation(), t.position(k) - e.mean(0), t.velocity(k) - e.mean(1));
          add(corrected, filter.innovation(), t.position(k) - p.mean(0), t.velocity(k) - p.mean(1));
          add(floor, known_report.innovation(0), t.position(k) - known.mean(0),
              t.velocity(k) - known.mean(1));
          ++samples;
          scan[0] = 1.0;
          scan[1] = filter.acceleration();
          scan[2] = std::pow(t.position(k) - e.mean(0), 2);
          scan[3] = std::pow(t.position(k) - p.mean(0), 2);
          consistency(scan + 4, axis, k);
        }
        const double n = std::max(1, samples);
        Eigen::Map<Eigen::RowVector3d>(terms.data()) = cv / n;
        Eigen::Map<Eigen::RowVector3d>(terms.data() + 3) = corrected / n;
        Eigen::Map<Eigen::RowVector3d>(terms.data() + 6) = floor / n;
        Eigen::Map<Eigen::RowVector3d>(terms.data() + 9) = tuned / std::max(1, imm_samples);
      });
  // The figures, summed in run order.
  for (std::size_t run = 0; run < axes.size(); ++run) {
    const datasets::AxisTrajectory& t = axes[run];
    const auto c = static_cast<std::size_t>(data.tracks[run / 2].case_index);
    CaseResult& out = cases[c];
    if (case_runs[c] == 0) out.true_acceleration = t.acceleration_input;
    ++case_runs[c];
    const double* terms = all.data() + static_cast<std::ptrdiff_t>(run) * width;
    for (auto& rows : out.consistency) rows.emplace_back(Eigen::RowVectorXd::Constant(steps, kNaN));
    for (int k = 2; k < steps; ++k) {
      const double* scan = terms + kRunTerms + k * kPerScan;
      for (std::size_t i = 0; i < 4; ++i) out.consistency[i].back()(k) = scan[4 + i];
      if (scan[0] == 0.0) continue;
      out.mean_estimate(k) += scan[1];
      out.cv_position_rmse(k) += scan[2];
      out.corrected_position_rmse(k) += scan[3];
    }
    cv_runs[c].emplace_back(Eigen::Map<const Eigen::RowVector3d>(terms));
    corrected_runs[c].emplace_back(Eigen::Map<const Eigen::RowVector3d>(terms + 3));
    floor_runs[c].emplace_back(Eigen::Map<const Eigen::RowVector3d>(terms + 6));
    imm_runs[c].emplace_back(Eigen::Map<const Eigen::RowVector3d>(terms + 9));
  }
  auto stack = [](const std::vector<Eigen::RowVector3d>& rows) {
    Eigen::MatrixXd m(static_cast<Eigen::Index>(rows.size()), 3);
    for (std::size_t i = 0; i < rows.size(); ++i) m.row(static_cast<Eigen::Index>(i)) = rows[i];
    return m;
  };
  for (std::size_t c = 0; c < cases.size(); ++c) {
    cases[c].cv = stack(cv_runs[c]);
    cases[c].corrected = stack(corrected_runs[c]);
    cases[c].floor = stack(floor_runs[c]);
    cases[c].imm = stack(imm_runs[c]);
    const double n = std::max(1, case_runs[c]);
    cases[c].mean_estimate /= n;
    cases[c].cv_position_rmse = (cases[c].cv_position_rmse / n).cwiseSqrt();
    cases[c].corrected_position_rmse = (cases[c].corrected_position_rmse / n).cwiseSqrt();
  }

  // The table: per case and quantity, CV, corrected, the difference and the paper's.
  nlohmann::json metrics;
  int wins = 0, cells = 0;
  std::vector<std::string> losses;
  std::vector<std::vector<std::string>> table, imm_table;
  std::vector<std::string> findings;
  std::vector<FilterConsistency> consistency;
  for (const CaseResult& r : cases) {
    if (r.cv.rows() == 0) continue;
    std::vector<std::string> row = {r.name};
    nlohmann::json m = {{"name", r.name}, {"runs", r.cv.rows()}};
    for (int q = 0; q < 3; ++q) {
      const Eigen::VectorXd cv = r.cv.col(q), corrected = r.corrected.col(q);
      const Difference d =
          paired_difference(static_cast<int>(cv.size()), mean_of(corrected), mean_of(cv));
      ++cells;
      if (d.below()) {
        ++wins;
      } else {
        losses.push_back(r.name + " " + kQuantity[q] + ": corrected − CV " + d.text(1));
      }
      const std::string metric = std::string(kQuantity[q]) + "_mse";
      const auto* paper_cv = regimes.evaluated.find("CV KF", r.name, metric);
      const auto* paper_corrected = regimes.evaluated.find("corrected KF", r.name, metric);
      auto with_paper = [](double ours, const datasets::PublishedFigure* paper) {
        return scientific(ours) + (paper ? " (" + scientific(paper->value) + ")" : "");
      };
      row.push_back(with_paper(cv.mean(), paper_cv));
      row.push_back(with_paper(corrected.mean(), paper_corrected));
      row.push_back(cell(corrected.mean() / cv.mean(), 3) +
                    (paper_cv && paper_corrected
                         ? " (" + cell(paper_corrected->value / paper_cv->value, 3) + ")"
                         : ""));
      row.push_back(std::string(d.below()   ? "yes "
                                : d.above() ? "no (worse) "
                                            : "tie ") +
                    interval_text(d));
      m["cv_kf"][metric] = cv.mean();
      m["corrected_kf"][metric] = corrected.mean();
      m["true_input_kf"][metric] = r.floor.col(q).mean();
      m["corrected_minus_cv"][metric] = {d.estimate, d.lower, d.upper};
    }
    row.push_back(scientific(r.floor.col(1).mean()));
    table.push_back(row);
    // Against the tuned classical filter: position and velocity.
    std::vector<std::string> imm_row = {r.name};
    std::array<Difference, 2> versus_tuned;
    for (int q : {1, 2}) {
      const Eigen::VectorXd tuned = r.imm.col(q), corrected = r.corrected.col(q);
      const Difference d =
          paired_difference(static_cast<int>(tuned.size()), mean_of(corrected), mean_of(tuned));
      versus_tuned[static_cast<std::size_t>(q - 1)] = d;
      const std::string metric = std::string(kQuantity[q]) + "_mse";
      m["imm_tuned"][metric] = tuned.mean();
      m["corrected_minus_imm_tuned"][metric] = {d.estimate, d.lower, d.upper};
      imm_row.push_back(scientific(tuned.mean()));
      imm_row.push_back(scientific(corrected.mean()));
      imm_row.push_back(interval_text(d));
    }
    const std::string verdict(evaluation::verdict(versus_tuned));
    imm_row.push_back(verdict);
    m["versus_imm_tuned"] = verdict;
    if (verdict != "beats") {
      findings.push_back(r.name + ": the corrected KF " + verdict + " IMM-tuned (position " +
                         imm_row[3] + ", velocity " + imm_row[6] + ")");
    }
    imm_table.push_back(imm_row);
    // Consistency of the corrected KF and IMM-tuned, per axis run (1-D position NEES and NIS).
    auto summary = [&r](std::size_t i) {
      return summarize_consistency(stacked(r.consistency[i]), 1);
    };
    consistency.push_back({r.name + ": corrected KF", summary(0), summary(1)});
    consistency.push_back({r.name + ": IMM-tuned", summary(2), summary(3)});
    m["corrected_kf"]["position_nees"] = consistency[consistency.size() - 2].position_nees.average;
    m["corrected_kf"]["nis"] = consistency[consistency.size() - 2].nis.average;
    m["imm_tuned"]["position_nees"] = consistency.back().position_nees.average;
    m["imm_tuned"]["nis"] = consistency.back().nis.average;
    metrics["rows"].push_back(m);
  }
  std::cout
      << "input-estimator: " << regimes.describe() << "\n  test split: " << data.tracks.size()
      << " tracks x " << steps << " scans (both axes: " << 2 * data.tracks.size() << " runs), seed "
      << options.seed << "\n  IMM-tuned: q " << comma_list(imm_tuned.spec.process_noise) << " ("
      << datasets::to_string(own.units) << "/s²)², stay " << imm_tuned.spec.settings.transition_stay
      << " (" << imm_tuned.evaluations << " evaluations on the training split of " << own.name
      << ")"
      << "\n\nMSE (the paper's in parentheses); ratio = corrected / CV; 'beats' = corrected − CV "
         "with its 95 % paired-bootstrap interval [lower, upper] lies below 0 (every figure "
         "is an error: below 0 the corrected KF is better):\n\n"
      << markdown_table({"case", "innov CV", "innov corrected", "ratio", "beats", "pos CV",
                         "pos corrected", "ratio", "beats", "vel CV", "vel corrected", "ratio",
                         "beats", "pos, true input (floor)"},
                        table);
  const bool passed = cells > 0 && wins >= kRequiredShare * cells;
  std::cout << "\nThe corrected KF beats the CV KF beyond the uncertainty in " << wins << " of "
            << cells << " cells.\nGates (the corrected KF beats the CV KF in at least "
            << 100.0 * kRequiredShare
            << " % of the cells; the paper: 22 of 24): " << (passed ? "passed" : "FAILED") << "\n";
  for (const auto& loss : losses) std::cout << "  - not better: " << loss << '\n';
  std::cout
      << "\nAgainst the tuned classical filter (corrected − IMM-tuned with its 95 % interval). "
      << kVerdictRule << "\n\n"
      << markdown_table({"case", "pos IMM-tuned", "pos corrected", "− IMM-tuned [95 %]",
                         "vel IMM-tuned", "vel corrected", "− IMM-tuned [95 %]", "verdict"},
                        imm_table)
      << "\nConsistency per axis run (1-D: position NEES and NIS average 1 when consistent):\n\n"
      << consistency_table(consistency);
  print_recorded_prediction(data, plot_outcomes, "corrected KF");
  // The 2-D filter a tracking engineer would set beside it (every table above is per axis).
  const nlohmann::json against_bar = compare_with_classical_bar(
      "corrected KF", [&] { return make_mlp_input_estimator_filter(model); }, model.track_options(),
      own, data, Eigen::Vector2d::Zero(), findings, options.classical);
  print_findings(findings);

  const std::filesystem::path& out = options.out;
  std::filesystem::create_directories(out);
  metrics["regime"] = {{"name", regime.name},
                       {"model_regime", regimes.trained.regime.name},
                       {"off_training", regimes.off_training()}};
  metrics["wins"] = wins;
  metrics["findings"] = findings;
  metrics["imm_tuned"] = {{"process_noise", imm_tuned.spec.process_noise},
                          {"stay", imm_tuned.spec.settings.transition_stay},
                          {"evaluations", imm_tuned.evaluations}};
  metrics["cells"] = cells;
  metrics["versus_classical_bar"] = against_bar;
  const HeadlineRuns evaluated{"input-estimator", model_path,   regime.name,
                               regime.digest,     options.seed, static_cast<int>(axes.size())};
  write_metrics(out, evaluated, definitions(std::string(datasets::to_string(regime.units))),
                metrics);
  write_headline(out, evaluated, corrected_headline(cases));

  // Fig. 4 and 5 of the seed: true vs estimated acceleration and the position RMSE over time, for
  // the first case and the middle one.
  std::vector<std::size_t> shown = {0};
  if (cases.size() > 1) shown.push_back(cases.size() / 2);
  for (std::size_t index : shown) {
    const CaseResult& r = cases[index];
    if (r.true_acceleration.size() == 0) continue;
    const std::string stem = "case" + std::to_string(index);
    Eigen::MatrixXd acceleration(steps, 2);
    acceleration << r.true_acceleration, r.mean_estimate;
    write_series_csv(out / (stem + "_acceleration.csv"), {"true", "estimated"}, acceleration);
    Eigen::MatrixXd position(steps, 2);
    position << r.cv_position_rmse, r.corrected_position_rmse;
    write_series_csv(out / (stem + "_position_rmse.csv"), {"cv_kf", "corrected_kf"}, position);
    plot_series({out / (stem + "_acceleration.png"),
                 r.name + ": true and mean estimated acceleration (seed 001 Fig. 4-5)",
                 "time (s)",
                 "acceleration",
                 out / (stem + "_acceleration.csv"),
                 {"true", "estimated"}});
    plot_series({out / (stem + "_position_rmse.png"),
                 r.name + ": position RMSE (seed 001 Fig. 4-5)",
                 "time (s)",
                 "position",
                 out / (stem + "_position_rmse.csv"),
                 {"cv_kf", "corrected_kf"}});
  }
  // The training curve stored in the model.
  if (reader.container().kind("/training/loss") == io::ObjectKind::kDataset) {
    const Eigen::MatrixXd loss = reader.matrix("/training/loss", -1, 3);
    write_series_csv(out / "training_loss.csv", {"epoch", "training_mse", "validation_mse"}, loss);
    plot_series({out / "training_loss.png",
                 "Training curve of the input estimator (MSE)",
                 "loss point (every loss_every epochs)",
                 "MSE",
                 out / "training_loss.csv",
                 {"training_mse", "validation_mse"}});
  }
  std::cout << "\nwrote metrics.json, CSV series and PNG plots in " << out.string() << '\n';
  if (!passed) return support::exit_code::kEvaluationGateFailed;
  return findings.empty() ? 0 : support::exit_code::kFindings;
}

}  // namespace

void add_input_estimator_command(CLI::App& app, ExitCode& exit_code) {
  auto options = std::make_shared<CommonOptions>();
  auto* command = app.add_subcommand(
      "input-estimator", "seed 001 Tables 1-2: neural input estimator vs the constant-velocity KF");
  add_common_options(*command, *options, "mlp_input_estimator", "reports/input-estimator");
  add_classical_option(*command, *options);
  command->callback([options, &exit_code] { exit_code = guarded([&] { return run(*options); }); });
}

}  // namespace imm::evaluation
