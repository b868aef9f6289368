// SPDX-License-Identifier: Apache-2.0
// `imm-eval fcm-imm`: seed 003's experiment (Fig. 5–8) on any regime with Cartesian plots. On
// the same test tracks: a single CV KF with q tuned (KF), the adaptive IMM tuned (AIMM), the
// constant-q IMM tuned (IMM-tuned), the learned FCM-IMM, and the same FCM-IMM with its
// memberships replaced by their training means (FCM-IMM-const, the ablation). The baselines are
// tuned on the training split of the model's regime with the trainer's objective — never on the
// test tracks. Position and velocity RMSE over every scored scan and over the scans where a
// maneuver acts.
//
// Gates: on the seed's own scenarios the FCM-IMM is below the KF and the AIMM in all four figures
// beyond the Monte Carlo uncertainty (95 % paired-bootstrap interval over tracks); on any other
// regime it is above neither in any figure beyond it. Findings (reported, exit 7 when they are
// all there is): off the seed's scenarios a figure where it only ties the KF or the AIMM, and
// beating IMM-tuned in fewer than two of the four. The ablation is reported, not gated.

#include <algorithm>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>
#include <span>
#include <sstream>

#include "imm/evaluation/classical_bar.hpp"
#include "imm/evaluation/consistency.hpp"
#include "imm/evaluation/evaluation_report.hpp"
#include "imm/evaluation/experiment.hpp"
#include "imm/evaluation/headline.hpp"
#include "imm/evaluation/monte_carlo.hpp"
#include "imm/evaluation/plot_metrics.hpp"
#include "imm/evaluation/report.hpp"
#include "imm/evaluation/uncertainty.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "imm/trainer/fcm/fcm_trainer.hpp"
#include "imm/trainer/normalized_errors.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/ranks.hpp"

namespace imm::evaluation {
namespace {

// The columns of the tables, for metrics.json and report.md.
std::vector<MetricDefinition> definitions(const std::string& length) {
  return {
      {"pos", length, "RMS position error over runs and scans"},
      {"vel", length + "/s", "RMS velocity error over runs and scans"},
      {"pos manoeuvre, vel manoeuvre", length + ", " + length + "/s",
       "the same over the scans where the manoeuvre acts"},
      {"fraction straight, fraction manoeuvre", "1",
       "FCM filters: mean manoeuvre fraction Σ_j μ_j (1 − u_noise,j) over both axes, outside and "
       "inside the manoeuvre"},
      {"training J", "1", "the fitting objective on the training split (lower is better)"},
      {"difference table", "as the column",
       "FCM-IMM minus the filter, 95 % paired-bootstrap interval over runs"},
  };
}

constexpr int kFirstScoredScan = 2;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr const char* kFigures[4] = {"pos_rmse", "vel_rmse", "pos_rmse_maneuver",
                                     "vel_rmse_maneuver"};

struct Outcome {
  std::string name;
  double figures[4] = {};  // kFigures
  /// Per track: Σ squared errors and the sample count, for each figure (tracks × 8).
  Eigen::MatrixXd per_track;
  Eigen::VectorXd position_rmse, velocity_rmse;  // per scan, over tracks
  /// FCM filters: the mean manoeuvre fraction Σ_j μ_j (1 − u_noise,j) (both axes), outside and
  /// inside the maneuvers, and per scan; NaN for the others.
  double fraction_straight = kNaN, fraction_maneuver = kNaN;
  Eigen::VectorXd fraction;
  Eigen::MatrixXd first_run;  // steps × 4 estimates of track 0 (x, vx, y, vy)
  long failed_steps = 0;
  ConsistencySummary position_nees, nis;
  Eigen::MatrixXd run_position_nees;  // runs × scans (NaN where a scan has no sample)

  [[nodiscard]] HeadlineMetric headline(int figure) const {
    const Eigen::Index column = Eigen::Index{2} * figure;
    return rms_metric(kFigures[figure], per_track.col(column), per_track.col(column + 1));
  }
  [[nodiscard]] Statistic statistic(int figure) const { return headline(figure).statistic(); }
};

Outcome run_filter(const std::string& name, const trainer::fcm::FilterFactory& make,
                   const datasets::TrackSet& data, double sigma) {
  const int steps = data.scans;
  const double T = data.sample_period;
  const double r = sigma * sigma;
  const auto runs = static_cast<Eigen::Index>(data.tracks.size());
  Outcome out;
  out.name = name;
  out.per_track = Eigen::MatrixXd::Zero(runs, 8);
  Eigen::VectorXd position = Eigen::VectorXd::Zero(steps), velocity = position, fraction = position;
  Eigen::VectorXi samples = Eigen::VectorXi::Zero(steps);
  double f_straight = 0.0, f_maneuver = 0.0;
  long n_straight = 0, n_maneuver = 0;
  bool is_fcm = false;
  out.first_run = Eigen::MatrixXd::Constant(steps, 4, kNaN);
  // One run's terms: whether its filter is an FCM-IMM; per scan: counted, dp, dv, maneuvering,
  // the FCM fraction, the estimate (4), failed, position NEES, NIS.
  constexpr std::ptrdiff_t kPerScan = 12;
  const auto width = static_cast<int>(1 + steps * kPerScan);
  const std::vector<double> all =
      trainer::shared_items(static_cast<long>(runs), width, [&](long run, std::span<double> terms) {
        const datasets::Track& track = data.tracks[static_cast<std::size_t>(run)];
        const Eigen::MatrixXd& z = track.plots;
        std::unique_ptr<TwoAxisFilter> filter = make();
        const auto* fx = dynamic_cast<const FcmImmAxisFilter*>(&filter->axis(0));
        const auto* fy = dynamic_cast<const FcmImmAxisFilter*>(&filter->axis(1));
        const bool fcm = fx != nullptr && fy != nullptr;
        terms[0] = fcm ? 1.0 : 0.0;
        Eigen::VectorXd mean(4);
        Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(4, 4);
        for (Eigen::Index axis = 0; axis < 2; ++axis) {
          mean.segment<2>(2 * axis) << z(1, axis), (z(1, axis) - z(0, axis)) / T;
          covariance.block<2, 2>(2 * axis, 2 * axis) << r, r / T, r / T, 2.0 * r / (T * T);
        }
        filter->initialize(mean, covariance);
        Eigen::VectorXd estimate(4), variance(4);
        for (int k = kFirstScoredScan; k < steps; ++k) {
          double* scan = terms.data() + 1 + k * kPerScan;
          if (filter->step(z.row(k).transpose()) != StepStatus::kOk) {
            scan[9] = 1.0;
            continue;
          }
          filter->state(estimate, variance);
          const Eigen::Vector2d p = datasets::position_at(track, k),
                                v = datasets::velocity_at(track, k);
          scan[0] = 1.0;
          scan[1] = std::pow(estimate(0) - p(0), 2) + std::pow(estimate(2) - p(1), 2);
          scan[2] = std::pow(estimate(1) - v(0), 2) + std::pow(estimate(3) - v(1), 2);
          scan[3] = track.maneuvering[static_cast<std::size_t>(k)] ? 1.0 : 0.0;
          if (fcm) scan[4] = 0.5 * (fx->maneuver_fraction() + fy->maneuver_fraction());
          Eigen::Map<Eigen::Vector4d>(scan + 5) = estimate;
          const trainer::StepConsistency consistency = trainer::step_consistency(*filter, p);
          scan[10] = consistency.position_nees;
          scan[11] = consistency.nis;
        }
      });
  // The figures, summed in run order.
  Eigen::MatrixXd run_nees = Eigen::MatrixXd::Constant(runs, steps, kNaN), run_nis = run_nees;
  for (Eigen::Index run = 0; run < runs; ++run) {
    const double* terms = all.data() + run * width;
    is_fcm = terms[0] != 0.0;
    for (int k = kFirstScoredScan; k < steps; ++k) {
      const double* scan = terms + 1 + k * kPerScan;
      if (scan[9] != 0.0) ++out.failed_steps;
      if (scan[0] == 0.0) continue;
      const double dp = scan[1], dv = scan[2];
      position(k) += dp;
      velocity(k) += dv;
      ++samples(k);
      const bool maneuvering = scan[3] != 0.0;
      run_nees(run, k) = scan[10];
      run_nis(run, k) = scan[11];
      out.per_track.row(run).head<4>() += Eigen::RowVector4d(dp, 1.0, dv, 1.0);
      if (maneuvering) out.per_track.row(run).tail<4>() += Eigen::RowVector4d(dp, 1.0, dv, 1.0);
      if (is_fcm) {
        const double f = scan[4];
        fraction(k) += f;
        (maneuvering ? f_maneuver : f_straight) += f;
        ++(maneuvering ? n_maneuver : n_straight);
      }
      if (run == 0) out.first_run.row(k) = Eigen::Map<const Eigen::RowVector4d>(scan + 5);
    }
  }
  out.position_rmse = Eigen::VectorXd::Constant(steps, kNaN);
  out.velocity_rmse = out.position_rmse;
  out.fraction = out.position_rmse;
  for (int k = kFirstScoredScan; k < steps; ++k) {
    if (samples(k) == 0) continue;
    out.position_rmse(k) = std::sqrt(position(k) / samples(k));
    out.velocity_rmse(k) = std::sqrt(velocity(k) / samples(k));
    if (is_fcm) out.fraction(k) = fraction(k) / samples(k);
  }
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(runs);
  for (int f = 0; f < 4; ++f) out.figures[f] = out.statistic(f)(ones);
  out.position_nees = summarize_consistency(run_nees, 2);
  out.nis = summarize_consistency(run_nis, 2);
  out.run_position_nees = std::move(run_nees);
  if (is_fcm) {
    out.fraction_straight = n_straight > 0 ? f_straight / static_cast<double>(n_straight) : kNaN;
    out.fraction_maneuver = n_maneuver > 0 ? f_maneuver / static_cast<double>(n_maneuver) : kNaN;
  }
  return out;
}

std::string describe(const std::vector<double>& values) {
  std::ostringstream text;
  text.precision(4);
  for (std::size_t i = 0; i < values.size(); ++i) text << (i ? ", " : "") << values[i];
  return text.str();
}

int run(const CommonOptions& options) {
  const std::filesystem::path model_path = options.model_path();
  const io::ModelFileReader reader(model_path, io::kFcmImmKind);
  const FcmImmSpec fitted = io::read_fcm_imm(model_path);
  const EvaluationRegimes regimes = evaluation_regimes(options, reader.provenance(), model_path);
  check_model({fitted.sample_period, datasets::SensorKind::kCartesian, fitted.measurement_sigma,
               std::nullopt},
              regimes, model_path);
  const datasets::Regime& regime = regimes.evaluated.regime;
  FcmImmSpec constant = fitted;
  constant.constant_memberships = true;

  // Baselines, tuned on the model's training split with the trainer's objective and search box,
  // from the training config the model recorded: IMM-tuned is then the very IMM the trainer
  // started from (its λ = 0 member), so a model whose learned part is off ties it. A model that
  // recorded no such config gets the search from its own settings.
  std::string note;
  const trainer::fcm::FcmTrainingConfig tuning = trainer::fcm::model_training_config(
      reader.provenance().config_toml, model_path.string() + " (/@config_toml)",
      regimes.trained.regime, fitted, note);
  if (!note.empty()) std::cerr << "fcm-imm: " << model_path.string() << ": " << note << '\n';
  const datasets::TrackSet training =
      datasets::draw_split(tuning.regime, datasets::Split::kTraining, 0);
  const auto kf = trainer::fcm::tune_kf(tuning, training);
  const auto aimm = trainer::fcm::tune_aimm(tuning, training);
  const auto imm = trainer::fcm::tune_cv_imm(tuning, training);
  const double sigma = fitted.measurement_sigma;

  // Every quantity with its unit: q in (length/s²)², accelerations and their σ in length/s².
  const std::string length(datasets::to_string(tuning.regime.units));
  const std::string q_unit = " (" + length + "/s²)²", a_unit = " " + length + "/s²";
  std::map<std::string, std::string> parameters;
  std::ostringstream text;
  text << "q " << describe(kf.spec.process_noise) << q_unit << " (" << kf.evaluations
       << " evaluations)";
  parameters["KF"] = text.str();
  text.str("");
  text << "ε " << describe(aimm.spec.intervals) << a_unit << ", σ_w "
       << aimm.spec.process_noise_sigma << a_unit << ", σ_b " << aimm.spec.bias_noise_sigma
       << a_unit << " (" << aimm.evaluations << " evaluations)";
  parameters["AIMM"] = text.str();
  text.str("");
  text << "q " << describe(imm.spec.process_noise) << q_unit << ", stay "
       << imm.spec.settings.transition_stay << " (" << imm.evaluations << " evaluations)";
  parameters["IMM-tuned"] = text.str();
  text.str("");
  text << "q " << describe(fitted.process_noise) << q_unit << ", stay " << fitted.transition(0, 0)
       << ", window " << fitted.window << ", m " << fitted.clustering.fuzzifier << ", κ "
       << fitted.separation << ", λ " << fitted.compensation_gain << ", " << to_string(fitted.scale)
       << " memberships" << (fitted.compensate_lowest ? "" : ", lowest mode uncompensated");
  parameters["FCM-IMM"] = text.str();
  std::map<std::string, double> training_objective;
  auto objective = [&](const trainer::fcm::FilterFactory& make) {
    return trainer::fcm::score_filter(make, training, sigma).objective;
  };
  training_objective["KF"] = kf.score.objective;
  training_objective["AIMM"] = aimm.score.objective;
  training_objective["IMM-tuned"] = imm.score.objective;
  training_objective["FCM-IMM"] = objective([&] { return make_fcm_imm_filter(fitted); });
  training_objective["FCM-IMM-const"] = objective([&] { return make_fcm_imm_filter(constant); });

  const datasets::TrackSet data = test_tracks(regime, options);
  const int runs = static_cast<int>(data.tracks.size());
  std::vector<Outcome> filters;
  const std::vector<std::pair<std::string, trainer::fcm::FilterFactory>> makers = {
      {"KF", [&] { return make_axis_cv_imm_filter(kf.spec); }},
      {"AIMM", [&] { return make_aimm_filter(aimm.spec); }},
      {"IMM-tuned", [&] { return make_axis_cv_imm_filter(imm.spec); }},
      {"FCM-IMM", [&] { return make_fcm_imm_filter(fitted); }},
      {"FCM-IMM-const", [&] { return make_fcm_imm_filter(constant); }}};
  // How well every filter predicts the plots (the judgement without truth; beside the errors on
  // recorded tracks with truth).
  const auto plot_outcomes = [&] {
    std::vector<FilterOutcome> outcomes;
    for (const auto& [name, make] : makers) {
      const trainer::fcm::FilterFactory& two_axis = make;
      outcomes.push_back(run_monte_carlo(
          name, [&two_axis]() -> std::unique_ptr<TrackFilter> { return two_axis(); },
          fitted.track_options(), data));
    }
    return outcomes;
  };
  if (!data.has_truth) {  // recorded plots without truth: judged by their prediction
    const std::vector<FilterOutcome> outcomes = plot_outcomes();
    std::cout << "fcm-imm: " << regimes.describe() << "\n  test split: " << runs << " tracks x "
              << data.scans << " scans; baselines tuned on the training split of "
              << tuning.regime.name << "\n\n";
    return plots_only_report(
        "fcm-imm", outcomes, "FCM-IMM", {"KF", "AIMM", "IMM-tuned"},
        {"fcm-imm", model_path, regime.name, regime.digest, options.seed, runs}, options.out);
  }
  filters.reserve(makers.size());
  for (const auto& [name, make] : makers) filters.push_back(run_filter(name, make, data, sigma));
  const Outcome& fcm = find_filter(filters, "FCM-IMM");

  std::cout << "fcm-imm: " << regimes.describe() << "\n  test split: " << runs << " tracks x "
            << data.scans << " scans, seed " << options.seed
            << "; baselines tuned on the training split of " << tuning.regime.name << "\n";
  for (const auto& [name, value] : parameters) std::cout << "  " << name << ": " << value << "\n";
  std::vector<std::vector<std::string>> rows;
  nlohmann::json metrics, details;
  // Four significant digits for the figures, whatever the length unit (0.1 km would hide the
  // differences the table below reports).
  int figure_decimals = 1;
  for (const auto& f : filters) {
    for (int i = 0; i < 4; ++i) {
      if (f.figures[i] > 0.0 && std::isfinite(f.figures[i])) {
        figure_decimals =
            std::max(figure_decimals, 3 - static_cast<int>(std::floor(std::log10(f.figures[i]))));
      }
    }
  }
  figure_decimals = std::min(figure_decimals, 6);
  for (const auto& f : filters) {
    std::vector<std::string> row = {f.name};
    for (int i = 0; i < 4; ++i) row.push_back(cell(f.figures[i], figure_decimals));
    row.push_back(cell(f.fraction_straight, 3));
    row.push_back(cell(f.fraction_maneuver, 3));
    row.push_back(cell(training_objective.at(f.name), 4));
    rows.push_back(row);
    for (int i = 0; i < 4; ++i) metrics[f.name][kFigures[i]] = f.figures[i];
    details[f.name] = {{"maneuver_fraction_straight", f.fraction_straight},
                       {"maneuver_fraction_maneuver", f.fraction_maneuver},
                       {"training_objective", training_objective.at(f.name)},
                       {"position_nees", f.position_nees.average},
                       {"nis", f.nis.average},
                       {"failed_steps", f.failed_steps}};
  }
  std::cout << "\nPosition and velocity RMSE (over tracks and scans 2 on, and over the scans where "
               "a maneuver acts), manoeuvre fraction 1 − μ_noise (straight / manoeuvre), "
               "training J:\n\n"
            << markdown_table({"filter", "pos", "vel", "pos manoeuvre", "vel manoeuvre",
                               "fraction straight", "fraction manoeuvre", "training J"},
                              rows);
  std::vector<FilterConsistency> consistency;
  consistency.reserve(filters.size());
  for (const auto& f : filters) consistency.push_back({f.name, f.position_nees, f.nis});
  std::cout << "\nConsistency:\n\n" << consistency_table(consistency);
  print_recorded_prediction(data, plot_outcomes, "FCM-IMM");
  // A fit that drove λ to 0 ships as the tuned IMM (fcm_trainer.hpp,
  // FcmTrainingResult::learned_part_on): say so beside the verdicts.
  const bool part_off = learned_part_off(reader.provenance());
  if (part_off) {
    std::cout << "\nFCM-IMM's learned part is switched off: no fit with a compensation beat the "
                 "constant-q IMM on its training split, so the model is that IMM (λ = 0).\n";
  }
  details["learned_part_on"] = !part_off;
  std::vector<std::string> failures, findings;
  std::vector<std::vector<std::string>> versus_rows;
  const bool paper = paper_scenario(regime);
  for (const auto& other : filters) {
    if (other.name == fcm.name) continue;
    std::vector<std::string> row = {other.name};
    int better = 0;
    for (int i = 0; i < 4; ++i) {
      const Difference d = paired_difference(runs, fcm.statistic(i), other.statistic(i));
      row.push_back(d.text(1));
      details["fcm_imm_minus"][other.name][kFigures[i]] = {d.estimate, d.lower, d.upper};
      better += d.below() ? 1 : 0;
      if ((other.name == "KF" || other.name == "AIMM") && !d.below()) {
        // The seed's claim on its own scenario; elsewhere only "not worse" is a gate.
        (paper || d.above() ? failures : findings)
            .push_back(std::string("FCM-IMM's ") + kFigures[i] + " is " +
                       (d.above() ? "above " : "not below ") + other.name +
                       "'s beyond the uncertainty (" + d.text(2) + ")");
      }
    }
    if (other.name == "IMM-tuned" && better < 2) {
      findings.push_back("FCM-IMM beats IMM-tuned in " + std::to_string(better) +
                         " of its four figures (fewer than two)" +
                         (part_off ? ": its learned part is switched off" : ""));
    }
    versus_rows.push_back(row);
  }
  std::cout << "\nFCM-IMM − each filter, with the 95 % paired-bootstrap interval (< 0: FCM-IMM "
               "better):\n\n"
            << markdown_table({"filter", "pos", "vel", "pos manoeuvre", "vel manoeuvre"},
                              versus_rows);
  // The 2-D filter a tracking engineer would set for the regime, on the same tracks.
  details["versus_classical_bar"] = compare_with_classical_bar(
      "FCM-IMM", [&]() -> std::unique_ptr<TrackFilter> { return make_fcm_imm_filter(fitted); },
      fitted.track_options(), tuning.regime, data, Eigen::Vector2d::Zero(), findings,
      options.classical);
  std::cout << "\nGates (FCM-IMM "
            << (paper ? "below KF and AIMM in all four (the seed's scenario)"
                      : "not above KF and AIMM in any of the four (a regime beyond the seed)")
            << ", beyond the uncertainty): " << (failures.empty() ? "passed" : "FAILED") << '\n';
  for (const auto& failure : failures) std::cout << "  - " << failure << '\n';
  print_findings(findings);

  const std::filesystem::path& out = options.out;
  std::filesystem::create_directories(out);
  details["runs"] = runs;
  details["seed"] = options.seed;
  details["regime"] = {{"name", regime.name},
                       {"model_regime", tuning.regime.name},
                       {"off_training", regimes.off_training()}};
  details["dataset_digest"] = data.digest();
  details["parameters"] = parameters;
  details["gate_failures"] = failures;
  details["findings"] = findings;
  const HeadlineRuns evaluated{"fcm-imm",     model_path,   regime.name,
                               regime.digest, options.seed, runs};
  write_metrics(out, evaluated, definitions(std::string(datasets::to_string(regime.units))),
                metrics);
  trainer::write_json_atomically(out / "details.json", details);
  // The four figures, and how far the covariance is from the errors (a candidate whose
  // consistency got worse beyond its interval is held back like a less accurate one).
  write_headline(out, evaluated,
                 {fcm.headline(0), fcm.headline(1), fcm.headline(2), fcm.headline(3),
                  nees_log_ratio_metric("position_nees_log_ratio", fcm.run_position_nees, 2)});

  // Series and plots (seed Fig. 5, 7, 8).
  const int steps = data.scans;
  std::vector<std::string> names;
  Eigen::MatrixXd pos(steps, static_cast<Eigen::Index>(filters.size()));
  Eigen::MatrixXd vel = pos, fraction(steps, 2);
  for (std::size_t i = 0; i < filters.size(); ++i) {
    names.push_back(filters[i].name);
    pos.col(static_cast<Eigen::Index>(i)) = filters[i].position_rmse;
    vel.col(static_cast<Eigen::Index>(i)) = filters[i].velocity_rmse;
  }
  fraction << fcm.fraction, find_filter(filters, "FCM-IMM-const").fraction;
  write_series_csv(out / "position_rmse.csv", names, pos);
  write_series_csv(out / "velocity_rmse.csv", names, vel);
  write_series_csv(out / "maneuver_fraction.csv", {"FCM-IMM", "FCM-IMM-const"}, fraction);
  const datasets::Track& first = data.tracks.front();
  const double unit = regime.units == datasets::Units::kMetres ? 1e3 : 1.0;
  Eigen::MatrixXd path(steps, 8);
  path << first.truth.col(0) / unit, first.truth.col(3) / unit, first.plots.col(0) / unit,
      first.plots.col(1) / unit, find_filter(filters, "KF").first_run.col(0) / unit,
      find_filter(filters, "KF").first_run.col(2) / unit, fcm.first_run.col(0) / unit,
      fcm.first_run.col(2) / unit;
  write_series_csv(out / "trajectory_run0.csv",
                   {"truth_x", "truth", "plots_x", "plots", "KF_x", "KF", "FCM-IMM_x", "FCM-IMM"},
                   path);
  bool plotted = plot_series({out / "trajectory.png",
                              "Target path and track 0 (seed 003 Fig. 5, 7)",
                              "x (km)",
                              "y (km)",
                              out / "trajectory_run0.csv",
                              {"plots", "truth", "KF", "FCM-IMM"},
                              {"plots_x", "truth_x", "KF_x", "FCM-IMM_x"}});
  plotted &= plot_series({out / "position_rmse.png", "Position RMSE per scan (seed 003 Fig. 7)",
                          "scan k", "position", out / "position_rmse.csv", names});
  plotted &= plot_series({out / "velocity_rmse.png", "Velocity RMSE per scan (seed 003 Fig. 8)",
                          "scan k", "velocity", out / "velocity_rmse.csv", names});
  plotted &= plot_series({out / "maneuver_fraction.png",
                          "Mean manoeuvre fraction 1 - u_noise",
                          "scan k",
                          "fraction",
                          out / "maneuver_fraction.csv",
                          {"FCM-IMM", "FCM-IMM-const"}});
  return finish_report(out, plotted, failures, /*failures_printed=*/true, findings);
}

}  // namespace

void add_fcm_imm_command(CLI::App& app, ExitCode& exit_code) {
  auto options = std::make_shared<CommonOptions>();
  auto* command = app.add_subcommand(
      "fcm-imm",
      "seed 003 Fig. 5-8: FCM-IMM vs KF, AIMM, tuned IMM and the constant-membership ablation");
  add_common_options(*command, *options, "fcm_imm", "reports/fcm-imm");
  add_classical_option(*command, *options);
  command->callback([options, &exit_code] { exit_code = guarded([&] { return run(*options); }); });
}

}  // namespace imm::evaluation
