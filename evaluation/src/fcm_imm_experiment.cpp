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
#include <array>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "imm/evaluation/classical_bar.hpp"
#include "imm/evaluation/consistency.hpp"
#include "imm/evaluation/evaluation_report.hpp"
#include "imm/evaluation/experiment.hpp"
#include "imm/evaluation/experiments.hpp"
#include "imm/evaluation/fcm_imm_outcome.hpp"
#include "imm/evaluation/headline.hpp"
#include "imm/evaluation/monte_carlo.hpp"
#include "imm/evaluation/plot_metrics.hpp"
#include "imm/evaluation/report.hpp"
#include "imm/evaluation/uncertainty.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "imm/trainer/fcm/fcm_trainer.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::evaluation {
namespace {

// The columns of the tables, for metrics.json and report.md.
std::vector<MetricDefinition> fcm_imm_definitions(const std::string& length) {
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

std::string describe(const std::vector<double>& values) {
  std::ostringstream text;
  text.precision(4);
  for (std::size_t i = 0; i < values.size(); ++i) text << (i ? ", " : "") << values[i];
  return text.str();
}

// FCM-IMM − each filter in the four figures; the gates and findings (the file comment).
void judge(FcmImmResult& r) {
  const FcmImmOutcome& fcm = r.outcome("FCM-IMM");
  for (const auto& other : r.outcomes) {
    if (other.name == fcm.name) continue;
    std::array<Difference, 4>& differences = r.fcm_imm_minus[other.name];
    int better = 0;
    for (int i = 0; i < 4; ++i) {
      const Difference d = paired_difference(r.runs(), fcm.statistic(i), other.statistic(i));
      differences[static_cast<std::size_t>(i)] = d;
      better += d.below() ? 1 : 0;
      if ((other.name == "KF" || other.name == "AIMM") && !d.below()) {
        // The seed's claim on its own scenario; elsewhere only "not worse" is a gate.
        (r.paper_scenario || d.above() ? r.failures : r.findings)
            .push_back(std::string("FCM-IMM's ") + kFcmImmFigures[i] + " is " +
                       (d.above() ? "above " : "not below ") + other.name +
                       "'s beyond the uncertainty (" + d.text(2) + ")");
      }
    }
    if (other.name == "IMM-tuned" && better < 2) {
      r.findings.push_back("FCM-IMM beats IMM-tuned in " + std::to_string(better) +
                           " of its four figures (fewer than two)" +
                           (r.learned_part_on ? "" : ": its learned part is switched off"));
    }
  }
}

// The series and plots (seed Fig. 5, 7, 8); false when a plot failed.
bool write_series(const FcmImmResult& r, const std::filesystem::path& out) {
  const std::vector<FcmImmOutcome>& filters = r.outcomes;
  const FcmImmOutcome& fcm = r.outcome("FCM-IMM");
  const int steps = r.tracks.scans;
  std::vector<std::string> names;
  Eigen::MatrixXd pos(steps, static_cast<Eigen::Index>(filters.size()));
  Eigen::MatrixXd vel = pos, fraction(steps, 2);
  for (std::size_t i = 0; i < filters.size(); ++i) {
    names.push_back(filters[i].name);
    pos.col(static_cast<Eigen::Index>(i)) = filters[i].position_rmse;
    vel.col(static_cast<Eigen::Index>(i)) = filters[i].velocity_rmse;
  }
  fraction << fcm.fraction, r.outcome("FCM-IMM-const").fraction;
  write_series_csv(out / "position_rmse.csv", names, pos);
  write_series_csv(out / "velocity_rmse.csv", names, vel);
  write_series_csv(out / "maneuver_fraction.csv", {"FCM-IMM", "FCM-IMM-const"}, fraction);
  const datasets::Track& first = r.tracks.tracks.front();
  const double unit = r.regimes.evaluated.regime.units == datasets::Units::kMetres ? 1e3 : 1.0;
  Eigen::MatrixXd path(steps, 8);
  path << first.truth.col(0) / unit, first.truth.col(3) / unit, first.plots.col(0) / unit,
      first.plots.col(1) / unit, r.outcome("KF").first_run.col(0) / unit,
      r.outcome("KF").first_run.col(2) / unit, fcm.first_run.col(0) / unit,
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
  return plotted;
}

}  // namespace

const FcmImmOutcome& FcmImmResult::outcome(const std::string& name) const {
  for (const FcmImmOutcome& o : outcomes) {
    if (o.name == name) return o;
  }
  throw std::out_of_range("fcm-imm: no filter named '" + name + "'");
}

FcmImmResult evaluate_fcm_imm(const FcmImmOptions& options) {
  FcmImmResult r;
  const io::ModelFileReader reader(options.common.model_path(), io::kFcmImmKind);
  r.start("fcm-imm", options.common, reader.provenance());
  const FcmImmSpec fitted = io::read_fcm_imm(r.model);
  check_model({fitted.sample_period, datasets::SensorKind::kCartesian, fitted.measurement_sigma,
               std::nullopt},
              r.regimes, r.model);
  const datasets::Regime& regime = r.regimes.evaluated.regime;
  r.paper_scenario = paper_scenario(regime);
  r.learned_part_on = !learned_part_off(reader.provenance());
  FcmImmSpec constant = fitted;
  constant.constant_memberships = true;

  // Baselines, tuned on the model's training split with the trainer's objective and search box,
  // from the training config the model recorded: IMM-tuned is then the very IMM the trainer
  // started from (its λ = 0 member), so a model whose learned part is off ties it. A model that
  // recorded no such config gets the search from its own settings.
  const trainer::fcm::FcmTrainingConfig tuning = trainer::fcm::model_training_config(
      reader.provenance().config_toml, r.model.string() + " (/@config_toml)",
      r.regimes.trained.regime, fitted, r.tuning_note);
  r.tuning_regime = tuning.regime.name;
  const datasets::TrackSet training =
      datasets::draw_split(tuning.regime, datasets::Split::kTraining, 0);
  const auto kf = trainer::fcm::tune_kf(tuning, training);
  const auto aimm = trainer::fcm::tune_aimm(tuning, training);
  const auto imm = trainer::fcm::tune_cv_imm(tuning, training);
  const double sigma = fitted.measurement_sigma;

  // Every quantity with its unit: q in (length/s²)², accelerations and their σ in length/s².
  const std::string length(datasets::to_string(tuning.regime.units));
  const std::string q_unit = " (" + length + "/s²)²", a_unit = " " + length + "/s²";
  std::ostringstream text;
  text << "q " << describe(kf.spec.process_noise) << q_unit << " (" << kf.evaluations
       << " evaluations)";
  r.parameters["KF"] = text.str();
  text.str("");
  text << "ε " << describe(aimm.spec.intervals) << a_unit << ", σ_w "
       << aimm.spec.process_noise_sigma << a_unit << ", σ_b " << aimm.spec.bias_noise_sigma
       << a_unit << " (" << aimm.evaluations << " evaluations)";
  r.parameters["AIMM"] = text.str();
  text.str("");
  text << "q " << describe(imm.spec.process_noise) << q_unit << ", stay "
       << imm.spec.settings.transition_stay << " (" << imm.evaluations << " evaluations)";
  r.parameters["IMM-tuned"] = text.str();
  text.str("");
  text << "q " << describe(fitted.process_noise) << q_unit << ", stay " << fitted.transition(0, 0)
       << ", window " << fitted.window << ", m " << fitted.clustering.fuzzifier << ", κ "
       << fitted.separation << ", λ " << fitted.compensation_gain << ", " << to_string(fitted.scale)
       << " memberships" << (fitted.compensate_lowest ? "" : ", lowest mode uncompensated");
  r.parameters["FCM-IMM"] = text.str();
  auto objective = [&](const trainer::fcm::FilterFactory& make) {
    return trainer::fcm::score_filter(make, training, sigma).objective;
  };
  r.training_objective["KF"] = kf.score.objective;
  r.training_objective["AIMM"] = aimm.score.objective;
  r.training_objective["IMM-tuned"] = imm.score.objective;
  r.training_objective["FCM-IMM"] = objective([&] { return make_fcm_imm_filter(fitted); });
  r.training_objective["FCM-IMM-const"] = objective([&] { return make_fcm_imm_filter(constant); });

  r.tracks = test_tracks(regime, options.common);
  const datasets::TrackSet& data = r.tracks;
  const std::vector<std::pair<std::string, trainer::fcm::FilterFactory>> makers = {
      {"KF", [&] { return make_axis_cv_imm_filter(kf.spec); }},
      {"AIMM", [&] { return make_aimm_filter(aimm.spec); }},
      {"IMM-tuned", [&] { return make_axis_cv_imm_filter(imm.spec); }},
      {"FCM-IMM", [&] { return make_fcm_imm_filter(fitted); }},
      {"FCM-IMM-const", [&] { return make_fcm_imm_filter(constant); }}};
  // How well every filter predicts the plots (the judgement without truth; beside the errors on
  // recorded tracks with truth).
  if (!data.has_truth || data.recorded) {
    for (const auto& [name, make] : makers) {
      const trainer::fcm::FilterFactory& two_axis = make;
      r.filters.push_back(run_monte_carlo(
          name, [&two_axis]() -> std::unique_ptr<TrackFilter> { return two_axis(); },
          fitted.track_options(), data));
    }
  }
  if (!data.has_truth) return r;  // judged by the plots' prediction in the report
  r.outcomes.reserve(makers.size());
  for (const auto& [name, make] : makers) {
    r.outcomes.push_back(run_fcm_imm_filter(name, make, data, sigma));
  }
  judge(r);
  // The 2-D filter a tracking engineer would set for the regime, on the same tracks.
  r.versus_bar = compare_with_bar(
      "FCM-IMM", [&]() -> std::unique_ptr<TrackFilter> { return make_fcm_imm_filter(fitted); },
      fitted.track_options(), tuning.regime, data, Eigen::Vector2d::Zero(),
      options.common.classical);
  if (r.versus_bar && r.versus_bar->verdict != "beats") r.findings.push_back(r.versus_bar->summary);
  return r;
}

int report_fcm_imm(const FcmImmResult& r, const FcmImmOptions& options) {
  if (!r.tuning_note.empty()) {
    std::cerr << "fcm-imm: " << r.model.string() << ": " << r.tuning_note << '\n';
  }
  const datasets::Regime& regime = r.regimes.evaluated.regime;
  const datasets::TrackSet& data = r.tracks;
  const int runs = r.runs();
  const std::filesystem::path& out = options.common.out;
  if (!data.has_truth) {  // recorded plots without truth: judged by their prediction
    std::cout << "fcm-imm: " << r.regimes.describe() << "\n  test split: " << runs << " tracks x "
              << data.scans << " scans; baselines tuned on the training split of "
              << r.tuning_regime << "\n\n";
    return plots_only_report("fcm-imm", r.filters, "FCM-IMM", {"KF", "AIMM", "IMM-tuned"},
                             {"fcm-imm", r.model, regime.name, regime.digest, r.seed, runs}, out);
  }
  const std::vector<FcmImmOutcome>& filters = r.outcomes;
  const FcmImmOutcome& fcm = r.outcome("FCM-IMM");
  std::cout << "fcm-imm: " << r.regimes.describe() << "\n  test split: " << runs << " tracks x "
            << data.scans << " scans, seed " << r.seed
            << "; baselines tuned on the training split of " << r.tuning_regime << "\n";
  for (const auto& [name, value] : r.parameters) {
    std::cout << "  " << name << ": " << value << "\n";
  }
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
    const double training = r.training_objective.at(f.name);
    std::vector<std::string> row = {f.name};
    for (int i = 0; i < 4; ++i) row.push_back(cell(f.figures[i], figure_decimals));
    row.push_back(cell(f.fraction_straight, 3));
    row.push_back(cell(f.fraction_maneuver, 3));
    row.push_back(cell(training, 4));
    rows.push_back(row);
    for (int i = 0; i < 4; ++i) metrics[f.name][kFcmImmFigures[i]] = f.figures[i];
    details[f.name] = {{"maneuver_fraction_straight", f.fraction_straight},
                       {"maneuver_fraction_maneuver", f.fraction_maneuver},
                       {"training_objective", training},
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
  print_recorded_prediction(data, r.filters, "FCM-IMM");
  // A fit that drove λ to 0 ships as the tuned IMM (fcm_trainer.hpp,
  // FcmTrainingResult::learned_part_on): say so beside the verdicts.
  if (!r.learned_part_on) {
    std::cout << "\nFCM-IMM's learned part is switched off: no fit with a compensation beat the "
                 "constant-q IMM on its training split, so the model is that IMM (λ = 0).\n";
  }
  details["learned_part_on"] = r.learned_part_on;
  std::vector<std::vector<std::string>> versus_rows;
  for (const auto& other : filters) {
    if (other.name == fcm.name) continue;
    std::vector<std::string> row = {other.name};
    const std::array<Difference, 4>& differences = r.fcm_imm_minus.at(other.name);
    for (int i = 0; i < 4; ++i) {
      const Difference& d = differences[static_cast<std::size_t>(i)];
      row.push_back(d.text(1));
      details["fcm_imm_minus"][other.name][kFcmImmFigures[i]] = {d.estimate, d.lower, d.upper};
    }
    versus_rows.push_back(row);
  }
  std::cout << "\nFCM-IMM − each filter, with the 95 % paired-bootstrap interval (< 0: FCM-IMM "
               "better):\n\n"
            << markdown_table({"filter", "pos", "vel", "pos manoeuvre", "vel manoeuvre"},
                              versus_rows);
  details["versus_classical_bar"] = nullptr;
  if (r.versus_bar) {
    print_bar_comparison(*r.versus_bar);
    details["versus_classical_bar"] = r.versus_bar->json();
  }
  std::cout << "\nGates (FCM-IMM "
            << (r.paper_scenario
                    ? "below KF and AIMM in all four (the seed's scenario)"
                    : "not above KF and AIMM in any of the four (a regime beyond the seed)")
            << ", beyond the uncertainty): " << (r.failures.empty() ? "passed" : "FAILED") << '\n';
  for (const auto& failure : r.failures) std::cout << "  - " << failure << '\n';
  print_findings(r.findings);

  std::filesystem::create_directories(out);
  details["runs"] = runs;
  details["seed"] = r.seed;
  details["regime"] = {{"name", regime.name},
                       {"model_regime", r.tuning_regime},
                       {"off_training", r.regimes.off_training()}};
  details["dataset_digest"] = data.digest();
  details["parameters"] = r.parameters;
  details["gate_failures"] = r.failures;
  details["findings"] = r.findings;
  const HeadlineRuns evaluated{"fcm-imm", r.model, regime.name, regime.digest, r.seed, runs};
  write_metrics(out, evaluated, fcm_imm_definitions(std::string(datasets::to_string(regime.units))),
                metrics);
  trainer::write_json_atomically(out / "details.json", details);
  // The four figures, and how far the covariance is from the errors (a candidate whose
  // consistency got worse beyond its interval is held back like a less accurate one).
  write_headline(out, evaluated,
                 {fcm.headline(0), fcm.headline(1), fcm.headline(2), fcm.headline(3),
                  nees_log_ratio_metric("position_nees_log_ratio", fcm.run_position_nees, 2)});
  const bool plotted = write_series(r, out);
  return finish_report(out, plotted, r.failures, /*failures_printed=*/true, r.findings);
}

int run_fcm_imm(const FcmImmOptions& options) {
  return report_fcm_imm(evaluate_fcm_imm(options), options);
}

}  // namespace imm::evaluation
