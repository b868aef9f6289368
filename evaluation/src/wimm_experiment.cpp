// SPDX-License-Identifier: Apache-2.0
// `imm-eval wimm`: seed 004's experiment (Table 2) on any regime with a polar sensor. Per case of
// the regime (seed 004's scenario 1, constant velocity, and 2, two coordinated turns), every
// filter on identical plots: the seed's normal IMM (nIMM), the weighted IMM of the model file
// (wIMM), the weighted IMM with the seed's own threshold and α (wIMM-seed), the correlated fusion
// (wIMM-correlated, equal to the nIMM by derivation), and the normal IMM with q₁ and P(CV→CV)
// tuned on the training split of the model's regime (nIMM-tuned).
//
// Gates, per case: the wIMM's settled azimuth error is below the nIMM's beyond the Monte Carlo
// uncertainty (95 % paired-bootstrap interval over tracks of the difference of the settled RMS
// errors) on the seed's own scenarios, and not above it on any other regime; its settled position
// error is not above the nIMM's beyond it. Findings (reported, exit 7 when they are all there
// is): off the seed's scenarios the wIMM only ties the nIMM, and wherever it is not below the
// nIMM-tuned in settled azimuth.
//
// A recorded regime without truth: the wIMM, the nIMM, the wIMM with the seed's fusion and the
// nIMM-tuned (tuned on the training split's plots) are judged by how well they predict the test
// plots (plot_metrics.hpp; the density of each plot before any fusion).

#include <iostream>
#include <nlohmann/json.hpp>
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
#include "imm/io/wimm_file.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/wimm/wimm_trainer.hpp"

namespace imm::evaluation {
namespace {

// The columns of the tables, for metrics.json and report.md.
std::vector<MetricDefinition> definitions(const std::string& length) {
  return {
      {"az (rad)", "rad",
       "RMS azimuth error of the estimate, over runs per scan, averaged over scans"},
      {"az settled", "rad", "the same over the settled scans (from the first settled scan on)"},
      {"ratio settled", "1", "settled azimuth error over the nIMM's"},
      {"− nIMM settled [95 %]", "rad",
       "settled RMS azimuth error minus the nIMM's, 95 % paired-bootstrap interval over tracks"},
      {"paper az, paper ratio", "rad, 1", "seed 004's published figures"},
      {"pos, pos settled", length, "RMS position error, all scans and settled scans"},
      {"NEES settled", "1", "mean position NEES over the settled scans (2 when consistent)"},
      {"fused", "1", "share of cycles that fused the azimuth"},
  };
}

using trainer::wimm::TrackingScore;

struct Row {
  std::string filter;
  TrackingScore score;
};

// √(weighted mean of per-track mean squares): the settled RMS error as a bootstrap statistic.
Statistic rms_of(const Eigen::VectorXd& per_track) {
  return [per_track](const Eigen::VectorXd& w) { return std::sqrt(w.dot(per_track) / w.sum()); };
}

// The wIMM's per-track settled mean squares of one case.
struct CaseHeadline {
  std::string name;
  Eigen::VectorXd azimuth, position;
  Eigen::MatrixXd run_position_nees;  // runs × scans
};

// Settled azimuth and position RMS per case, over all tracks in case order (a track of another
// case weighs nothing in a case's figure).
std::vector<HeadlineMetric> wimm_headline(const std::vector<CaseHeadline>& cases) {
  Eigen::Index runs = 0;
  for (const CaseHeadline& c : cases) runs += c.azimuth.size();
  std::vector<HeadlineMetric> headline;
  Eigen::Index offset = 0;
  for (const CaseHeadline& c : cases) {
    const Eigen::VectorXd ones = Eigen::VectorXd::Ones(c.azimuth.size());
    headline.push_back(
        in_case(rms_metric("az_rmse_settled " + c.name, c.azimuth, ones), offset, runs));
    headline.push_back(
        in_case(rms_metric("pos_rmse_settled " + c.name, c.position, ones), offset, runs));
    // How far each run's covariance is from its errors: a less consistent candidate is held back.
    headline.push_back(
        in_case(nees_log_ratio_metric("position_nees_log_ratio " + c.name, c.run_position_nees, 2),
                offset, runs));
    offset += c.azimuth.size();
  }
  return headline;
}

int run(const CommonOptions& options) {
  const std::filesystem::path model_path = options.model_path();
  const io::ModelFileReader reader(model_path, io::kWimmKind);
  const WimmSpec trained = io::read_wimm(model_path);
  const EvaluationRegimes regimes = evaluation_regimes(options, reader.provenance(), model_path);
  check_model({trained.sample_period, datasets::SensorKind::kPolar, trained.range_sigma,
               trained.azimuth_sigma},
              regimes, model_path);
  const datasets::Regime& regime = regimes.evaluated.regime;
  const Eigen::Vector2d& sensor = regime.sensor.position;

  // The seed's nIMM (the paper's baseline): the model's own nIMM, unless the model learned its
  // fusion on top of a tuned nIMM (configs/wimm_tuned.toml), whose q₁ and transition row then
  // give way to the seed's. nIMM-tuned searches from it, as the trainer's base does.
  const bool on_tuned = reader.provenance().training_metrics.contains("on_tuned_nimm");
  const bool part_off = learned_part_off(reader.provenance());
  WimmSpec normal = trained;
  normal.fusion = FusionVariant::kNone;
  if (on_tuned) {
    const WimmSpec seed;
    normal.cv_process_noise = seed.cv_process_noise;
    normal.transition = seed.transition;
  }
  WimmSpec seed_fusion = trained;
  seed_fusion.fusion = FusionVariant::kSeed;
  seed_fusion.threshold = 0.7;
  seed_fusion.alpha = 0.5;
  WimmSpec correlated = seed_fusion;
  correlated.fusion = FusionVariant::kCorrelated;
  correlated.update = MeasurementUpdate::kExtended;  // the derivation is for the polar update
  trainer::wimm::WimmTrainingConfig tuning;
  tuning.regime = regimes.trained.regime;
  tuning.filter = normal;
  const trainer::wimm::Tuned tuned_normal = trainer::wimm::tune_normal_imm(
      tuning, datasets::draw_split(tuning.regime, datasets::Split::kTraining, 0));

  std::map<std::string, std::string> parameters;
  std::ostringstream text;
  text << "threshold " << trained.threshold << ", alpha " << trained.alpha << " ("
       << to_string(trained.fusion) << " fusion, " << to_string(trained.update) << " update)";
  parameters["wIMM"] = text.str();
  text.str("");
  text << "q1 " << tuned_normal.spec.cv_process_noise << ", P(CV→CV) "
       << tuned_normal.spec.transition(0, 0) << " (" << tuned_normal.evaluations << " evaluations)";
  parameters["nIMM-tuned"] = text.str();

  const datasets::TrackSet data = test_tracks(regime, options);
  std::cout << "wimm: " << regimes.describe() << "\n  test split: " << data.tracks.size()
            << " tracks x " << data.scans << " scans, seed " << options.seed
            << "\n  wIMM: " << parameters.at("wIMM")
            << "\n  nIMM-tuned: " << parameters.at("nIMM-tuned") << "\n";
  if (on_tuned) {
    std::cout
        << "  the wIMM's fusion is learned on top of its nIMM tuned on the training split (q1 "
        << trained.cv_process_noise << ", P(CV→CV) " << trained.transition(0, 0)
        << "); nIMM is the seed's (q1 " << normal.cv_process_noise << ", P(CV→CV) "
        << normal.transition(0, 0) << ")"
        << (part_off ? "; its learned part is switched off: the fusion did not beat that "
                       "nIMM on the training and validation splits, so the model is it"
                     : "")
        << "\n";
  }
  // How well every filter predicts the plots (the judgement without truth; beside the errors on
  // recorded tracks with truth).
  const auto plot_outcomes = [&] {
    std::vector<FilterOutcome> outcomes;
    const auto evaluate = [&](const std::string& name, const WimmSpec& spec) {
      outcomes.push_back(run_monte_carlo(
          name, [&spec] { return std::make_unique<WimmFilter>(spec); }, spec.track_options(), data,
          {}, sensor));
    };
    evaluate("wIMM", trained);
    evaluate("nIMM", normal);
    evaluate("wIMM-seed", seed_fusion);
    evaluate("nIMM-tuned", tuned_normal.spec);
    return outcomes;
  };
  if (!data.has_truth) {  // recorded plots without truth: judged by their prediction
    const std::vector<FilterOutcome> outcomes = plot_outcomes();
    std::cout << "\n";
    return plots_only_report("wimm", outcomes, "wIMM", {"nIMM", "nIMM-tuned"},
                             {"wimm", model_path, regime.name, regime.digest, options.seed,
                              static_cast<int>(data.tracks.size())},
                             options.out);
  }
  const std::filesystem::path& out = options.out;
  std::filesystem::create_directories(out);
  nlohmann::json metrics, details;
  std::vector<std::string> failures, findings;
  bool plotted = true;
  const int settled = trainer::wimm::first_settled_scan(data.scans);
  std::vector<CaseHeadline> headline_cases;
  for (const CaseTracks& one_case : tracks_by_case(regime, data)) {
    const datasets::TrackSet& part = one_case.tracks;
    const std::string& case_name = one_case.name;
    std::vector<Row> rows;
    for (const auto& [name, spec] :
         std::vector<std::pair<std::string, WimmSpec>>{{"nIMM", normal},
                                                       {"wIMM", trained},
                                                       {"wIMM-seed", seed_fusion},
                                                       {"wIMM-correlated", correlated},
                                                       {"nIMM-tuned", tuned_normal.spec}}) {
      rows.push_back({name, trainer::wimm::score_tracking(spec, part, sensor)});
    }
    const int runs = static_cast<int>(part.tracks.size());
    const TrackingScore& n = rows.front().score;
    const TrackingScore& w = rows[1].score;
    std::vector<std::vector<std::string>> table;
    std::vector<FilterConsistency> consistency;
    for (const Row& row : rows) {
      const TrackingScore& s = row.score;
      const auto* paper = regimes.evaluated.find(row.filter, case_name, "azimuth_rmse");
      const auto* paper_normal = regimes.evaluated.find("nIMM", case_name, "azimuth_rmse");
      const Difference versus =
          paired_difference(runs, rms_of(s.track_azimuth_settled), rms_of(n.track_azimuth_settled));
      table.push_back(
          {row.filter, cell(s.azimuth, 5), cell(s.azimuth_settled, 5),
           cell(100.0 * s.azimuth_settled / n.azimuth_settled, 2) + " %",
           &row == &rows.front() ? "–" : versus.text(5), paper ? cell(paper->value, 4) : "–",
           paper && paper_normal ? cell(100.0 * paper->value / paper_normal->value, 2) + " %" : "–",
           cell(s.position, 1), cell(s.position_settled, 1), cell(s.nees_settled, 2),
           cell(100.0 * s.fused_fraction.tail(s.fused_fraction.size() - settled).mean(), 1) +
               " %"});
      metrics[case_name][row.filter] = {{"az_rmse", s.azimuth},
                                        {"az_rmse_settled", s.azimuth_settled},
                                        {"pos_rmse", s.position},
                                        {"pos_rmse_settled", s.position_settled},
                                        {"nees", s.nees_settled}};
      consistency.push_back({row.filter, summarize_consistency(s.run_position_nees, 2),
                             summarize_consistency(s.run_nis, 2)});
      details[case_name][row.filter] = {{"position_nees", consistency.back().position_nees.average},
                                        {"nis", consistency.back().nis.average}};
      if (&row != &rows.front()) {
        metrics[case_name][row.filter]["az_settled_minus_nimm"] = {versus.estimate, versus.lower,
                                                                   versus.upper};
      }
    }
    std::cout << "\n"
              << case_name << " (RMSE over runs per scan, averaged over scans; settled = "
              << "scans " << settled + 1 << "–" << data.scans
              << "; − nIMM: difference of the settled RMS azimuth error, 95 % interval):\n\n"
              << markdown_table(
                     {"filter", "az (rad)", "az settled", "ratio settled", "− nIMM settled [95 %]",
                      "paper az", "paper ratio", "pos", "pos settled", "NEES settled", "fused"},
                     table)
              << "\nNEES settled: of the 4-D position–velocity state. Consistency over every scan "
                 "(the NIS of the plot, in range and azimuth, before any fusion):\n\n"
              << consistency_table(consistency);
    headline_cases.push_back(
        {case_name, w.track_azimuth_settled, w.track_position_settled, w.run_position_nees});
    const Difference azimuth =
        paired_difference(runs, rms_of(w.track_azimuth_settled), rms_of(n.track_azimuth_settled));
    const Difference position =
        paired_difference(runs, rms_of(w.track_position_settled), rms_of(n.track_position_settled));
    if (!azimuth.below() && (paper_scenario(regime) || azimuth.above())) {
      failures.push_back(case_name + ": the wIMM's settled azimuth error is " +
                         (azimuth.above() ? "above" : "not below") +
                         " the nIMM's beyond the uncertainty (" + azimuth.text(5) + " rad)");
    } else if (!azimuth.below()) {
      findings.push_back(case_name +
                         ": the wIMM's settled azimuth error ties the nIMM's (the seed's claim "
                         "that it is below does not hold on this regime: " +
                         azimuth.text(5) + " rad)");
    }
    if (position.above()) {
      failures.push_back(case_name +
                         ": the wIMM's settled position error is above the nIMM's "
                         "beyond the uncertainty (" +
                         position.text(1) + ")");
    }
    const TrackingScore& t = rows.back().score;  // nIMM-tuned
    const Difference against_tuned =
        paired_difference(runs, rms_of(w.track_azimuth_settled), rms_of(t.track_azimuth_settled));
    if (!against_tuned.below()) {
      findings.push_back(case_name +
                         ": the wIMM's settled azimuth error is not below nIMM-tuned's " +
                         "beyond the uncertainty (" + against_tuned.text(5) + " rad)" +
                         (part_off ? ": its learned part is switched off" : ""));
    }
    // Series: azimuth RMSE per scan, mode probabilities (seed Fig. 7, 8, 10, 11).
    std::vector<std::string> names;
    Eigen::MatrixXd az(w.azimuth_rmse.size(), static_cast<Eigen::Index>(rows.size()));
    for (std::size_t r = 0; r < rows.size(); ++r) {
      names.push_back(rows[r].filter);
      az.col(static_cast<Eigen::Index>(r)) = rows[r].score.azimuth_rmse;
    }
    const std::string stem = "case" + std::to_string(one_case.index);
    write_series_csv(out / (stem + "_azimuth_rmse.csv"), names, az);
    Eigen::MatrixXd mu(w.azimuth_rmse.size(), 4);
    mu << n.mean_mode_probabilities, w.mean_mode_probabilities;
    write_series_csv(out / (stem + "_mode_probabilities.csv"),
                     {"nIMM_cv", "nIMM_singer", "wIMM_cv", "wIMM_singer"}, mu);
    plotted &= plot_series({out / (stem + "_azimuth_rmse.png"),
                            "Azimuth error RMSE, " + case_name + " (seed 004 Fig. 8, 11)",
                            "scan",
                            "rad",
                            out / (stem + "_azimuth_rmse.csv"),
                            {"nIMM", "wIMM", "nIMM-tuned"}});
    plotted &= plot_series({out / (stem + "_mode_probabilities.png"),
                            "Mean mode probabilities, " + case_name + " (seed 004 Fig. 7, 10)",
                            "scan",
                            "probability",
                            out / (stem + "_mode_probabilities.csv"),
                            {"nIMM_cv", "nIMM_singer", "wIMM_cv", "wIMM_singer"}});
  }
  if (regimes.evaluated.find("nIMM", regime.scripted() ? regime.case_name(0) : "",
                             "azimuth_rmse")) {
    std::cout << "\nThe paper's absolute azimuth errors (0.0249 rad = 1.43°) cannot come from "
                 "plots with σ_θ = 0.5° (0.0087 rad): they exceed the raw plot error. Compare the "
                 "ratios.\n";
  }
  print_recorded_prediction(data, plot_outcomes, "wIMM");
  // The 2-D filter a tracking engineer would set for the regime, on the same plots.
  details["versus_classical_bar"] = compare_with_classical_bar(
      "wIMM", [&] { return std::make_unique<WimmFilter>(trained); }, trained.track_options(),
      regimes.trained.regime, data, sensor, findings, options.classical);
  std::cout << "\nGates (settled azimuth "
            << (paper_scenario(regime) ? "below the nIMM's (the seed's scenario)"
                                       : "not above the nIMM's (a regime beyond the seed)")
            << ", position not above it, beyond the uncertainty): "
            << (failures.empty() ? "passed" : "FAILED") << '\n';
  for (const auto& failure : failures) std::cout << "  - " << failure << '\n';
  print_findings(findings);
  const HeadlineRuns evaluated{"wimm",        model_path,   regime.name,
                               regime.digest, options.seed, static_cast<int>(data.tracks.size())};
  write_metrics(out, evaluated, definitions(std::string(datasets::to_string(regime.units))),
                metrics);
  write_headline(out, evaluated, wimm_headline(headline_cases));
  details["parameters"] = parameters;
  details["regime"] = {{"name", regime.name},
                       {"model_regime", regimes.trained.regime.name},
                       {"off_training", regimes.off_training()}};
  details["runs"] = data.tracks.size();
  details["seed"] = options.seed;
  details["gate_failures"] = failures;
  details["findings"] = findings;
  trainer::write_json_atomically(out / "details.json", details);
  return finish_report(out, plotted, failures, /*failures_printed=*/true, findings);
}

}  // namespace

void add_wimm_command(CLI::App& app, ExitCode& exit_code) {
  auto options = std::make_shared<CommonOptions>();
  auto* command = app.add_subcommand(
      "wimm", "seed 004 Table 2: weighted IMM vs normal IMM and a tuned normal IMM");
  add_common_options(*command, *options, "wimm", "reports/wimm");
  add_classical_option(*command, *options);
  command->callback([options, &exit_code] { exit_code = guarded([&] { return run(*options); }); });
}

}  // namespace imm::evaluation
