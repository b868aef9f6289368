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
#include "imm/evaluation/experiments.hpp"
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
std::vector<MetricDefinition> wimm_definitions(const std::string& length) {
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

// Each case's rows, differences and verdicts (the file comment).
void judge_case(WimmResult& r, WimmCase& c) {
  const datasets::Regime& regime = r.regimes.evaluated.regime;
  const TrackingScore& n = c.scores.front();
  const TrackingScore& w = c.scores[1];
  for (std::size_t k = 0; k < c.scores.size(); ++k) {
    c.versus_nimm.push_back(paired_difference(c.runs, rms_of(c.scores[k].track_azimuth_settled),
                                              rms_of(n.track_azimuth_settled)));
    c.consistency.push_back({c.filters[k], summarize_consistency(c.scores[k].run_position_nees, 2),
                             summarize_consistency(c.scores[k].run_nis, 2)});
  }
  const Difference& azimuth = c.versus_nimm[1];
  const Difference position =
      paired_difference(c.runs, rms_of(w.track_position_settled), rms_of(n.track_position_settled));
  if (!azimuth.below() && (paper_scenario(regime) || azimuth.above())) {
    r.failures.push_back(c.name + ": the wIMM's settled azimuth error is " +
                         (azimuth.above() ? "above" : "not below") +
                         " the nIMM's beyond the uncertainty (" + azimuth.text(5) + " rad)");
  } else if (!azimuth.below()) {
    r.findings.push_back(c.name +
                         ": the wIMM's settled azimuth error ties the nIMM's (the seed's claim "
                         "that it is below does not hold on this regime: " +
                         azimuth.text(5) + " rad)");
  }
  if (position.above()) {
    r.failures.push_back(c.name +
                         ": the wIMM's settled position error is above the nIMM's "
                         "beyond the uncertainty (" +
                         position.text(1) + ")");
  }
  const TrackingScore& t = c.scores.back();  // nIMM-tuned
  const Difference against_tuned =
      paired_difference(c.runs, rms_of(w.track_azimuth_settled), rms_of(t.track_azimuth_settled));
  if (!against_tuned.below()) {
    r.findings.push_back(c.name + ": the wIMM's settled azimuth error is not below nIMM-tuned's " +
                         "beyond the uncertainty (" + against_tuned.text(5) + " rad)" +
                         (r.learned_part_on ? "" : ": its learned part is switched off"));
  }
}

// One case's table and consistency on stdout, its entries of metrics and details, its series and
// plots in `out`; false when a plot failed.
bool report_case(const WimmResult& r, const WimmCase& c, nlohmann::json& metrics,
                 nlohmann::json& details, const std::filesystem::path& out) {
  const TrackingScore& n = c.scores.front();
  const TrackingScore& w = c.scores[1];
  std::vector<std::vector<std::string>> table;
  for (std::size_t k = 0; k < c.scores.size(); ++k) {
    const TrackingScore& s = c.scores[k];
    const std::string& filter = c.filters[k];
    const auto* paper = r.regimes.evaluated.find(filter, c.name, "azimuth_rmse");
    const auto* paper_normal = r.regimes.evaluated.find("nIMM", c.name, "azimuth_rmse");
    const Difference& versus = c.versus_nimm[k];
    table.push_back(
        {filter, cell(s.azimuth, 5), cell(s.azimuth_settled, 5),
         cell(100.0 * s.azimuth_settled / n.azimuth_settled, 2) + " %",
         k == 0 ? "–" : versus.text(5), paper ? cell(paper->value, 4) : "–",
         paper && paper_normal ? cell(100.0 * paper->value / paper_normal->value, 2) + " %" : "–",
         cell(s.position, 1), cell(s.position_settled, 1), cell(s.nees_settled, 2),
         cell(100.0 * s.fused_fraction.tail(s.fused_fraction.size() - r.settled).mean(), 1) +
             " %"});
    metrics[c.name][filter] = {{"az_rmse", s.azimuth},
                               {"az_rmse_settled", s.azimuth_settled},
                               {"pos_rmse", s.position},
                               {"pos_rmse_settled", s.position_settled},
                               {"nees", s.nees_settled}};
    details[c.name][filter] = {{"position_nees", c.consistency[k].position_nees.average},
                               {"nis", c.consistency[k].nis.average}};
    if (k != 0) {
      metrics[c.name][filter]["az_settled_minus_nimm"] = {versus.estimate, versus.lower,
                                                          versus.upper};
    }
  }
  std::cout << "\n"
            << c.name << " (RMSE over runs per scan, averaged over scans; settled = "
            << "scans " << r.settled + 1 << "–" << r.tracks.scans
            << "; − nIMM: difference of the settled RMS azimuth error, 95 % interval):\n\n"
            << markdown_table(
                   {"filter", "az (rad)", "az settled", "ratio settled", "− nIMM settled [95 %]",
                    "paper az", "paper ratio", "pos", "pos settled", "NEES settled", "fused"},
                   table)
            << "\nNEES settled: of the 4-D position–velocity state. Consistency over every scan "
               "(the NIS of the plot, in range and azimuth, before any fusion):\n\n"
            << consistency_table(c.consistency);
  // Series: azimuth RMSE per scan, mode probabilities (seed Fig. 7, 8, 10, 11).
  Eigen::MatrixXd az(w.azimuth_rmse.size(), static_cast<Eigen::Index>(c.scores.size()));
  for (std::size_t k = 0; k < c.scores.size(); ++k) {
    az.col(static_cast<Eigen::Index>(k)) = c.scores[k].azimuth_rmse;
  }
  const std::string stem = "case" + std::to_string(c.index);
  write_series_csv(out / (stem + "_azimuth_rmse.csv"), c.filters, az);
  Eigen::MatrixXd mu(w.azimuth_rmse.size(), 4);
  mu << n.mean_mode_probabilities, w.mean_mode_probabilities;
  write_series_csv(out / (stem + "_mode_probabilities.csv"),
                   {"nIMM_cv", "nIMM_singer", "wIMM_cv", "wIMM_singer"}, mu);
  bool plotted = plot_series({out / (stem + "_azimuth_rmse.png"),
                              "Azimuth error RMSE, " + c.name + " (seed 004 Fig. 8, 11)",
                              "scan",
                              "rad",
                              out / (stem + "_azimuth_rmse.csv"),
                              {"nIMM", "wIMM", "nIMM-tuned"}});
  plotted &= plot_series({out / (stem + "_mode_probabilities.png"),
                          "Mean mode probabilities, " + c.name + " (seed 004 Fig. 7, 10)",
                          "scan",
                          "probability",
                          out / (stem + "_mode_probabilities.csv"),
                          {"nIMM_cv", "nIMM_singer", "wIMM_cv", "wIMM_singer"}});
  return plotted;
}

}  // namespace

WimmResult evaluate_wimm(const WimmOptions& options) {
  WimmResult r;
  const io::ModelFileReader reader(options.common.model_path(), io::kWimmKind);
  r.start("wimm", options.common, reader.provenance());
  const WimmSpec trained = io::read_wimm(r.model);
  check_model({trained.sample_period, datasets::SensorKind::kPolar, trained.range_sigma,
               trained.azimuth_sigma},
              r.regimes, r.model);
  const datasets::Regime& regime = r.regimes.evaluated.regime;
  const Eigen::Vector2d& sensor = regime.sensor.position;

  // The seed's nIMM (the paper's baseline): the model's own nIMM, unless the model learned its
  // fusion on top of a tuned nIMM (configs/wimm_tuned.toml), whose q₁ and transition row then
  // give way to the seed's. nIMM-tuned searches from it, as the trainer's base does.
  r.on_tuned = reader.provenance().training_metrics.contains("on_tuned_nimm");
  r.learned_part_on = !learned_part_off(reader.provenance());
  WimmSpec normal = trained;
  normal.fusion = FusionVariant::kNone;
  if (r.on_tuned) {
    const WimmSpec seed;
    normal.cv_process_noise = seed.cv_process_noise;
    normal.transition = seed.transition;
  }
  r.trained_q1 = trained.cv_process_noise;
  r.trained_stay = trained.transition(0, 0);
  r.nimm_q1 = normal.cv_process_noise;
  r.nimm_stay = normal.transition(0, 0);
  WimmSpec seed_fusion = trained;
  seed_fusion.fusion = FusionVariant::kSeed;
  seed_fusion.threshold = 0.7;
  seed_fusion.alpha = 0.5;
  WimmSpec correlated = seed_fusion;
  correlated.fusion = FusionVariant::kCorrelated;
  correlated.update = MeasurementUpdate::kExtended;  // the derivation is for the polar update
  trainer::wimm::WimmTrainingConfig tuning;
  tuning.regime = r.regimes.trained.regime;
  tuning.filter = normal;
  const trainer::wimm::Tuned tuned_normal = trainer::wimm::tune_normal_imm(
      tuning, datasets::draw_split(tuning.regime, datasets::Split::kTraining, 0));

  std::ostringstream text;
  text << "threshold " << trained.threshold << ", alpha " << trained.alpha << " ("
       << to_string(trained.fusion) << " fusion, " << to_string(trained.update) << " update)";
  r.parameters["wIMM"] = text.str();
  text.str("");
  text << "q1 " << tuned_normal.spec.cv_process_noise << ", P(CV→CV) "
       << tuned_normal.spec.transition(0, 0) << " (" << tuned_normal.evaluations << " evaluations)";
  r.parameters["nIMM-tuned"] = text.str();

  r.tracks = test_tracks(regime, options.common);
  const datasets::TrackSet& data = r.tracks;
  // How well every filter predicts the plots (the judgement without truth; beside the errors on
  // recorded tracks with truth).
  if (!data.has_truth || data.recorded) {
    const auto evaluate = [&](const std::string& name, const WimmSpec& spec) {
      r.filters.push_back(run_monte_carlo(
          name, [&spec] { return std::make_unique<WimmFilter>(spec); }, spec.track_options(), data,
          {}, sensor));
    };
    evaluate("wIMM", trained);
    evaluate("nIMM", normal);
    evaluate("wIMM-seed", seed_fusion);
    evaluate("nIMM-tuned", tuned_normal.spec);
  }
  if (!data.has_truth) return r;  // judged by the plots' prediction in the report

  r.settled = trainer::wimm::first_settled_scan(data.scans);
  for (const CaseTracks& one_case : tracks_by_case(regime, data)) {
    WimmCase c;
    c.index = one_case.index;
    c.name = one_case.name;
    c.runs = static_cast<int>(one_case.tracks.tracks.size());
    for (const auto& [name, spec] :
         std::vector<std::pair<std::string, WimmSpec>>{{"nIMM", normal},
                                                       {"wIMM", trained},
                                                       {"wIMM-seed", seed_fusion},
                                                       {"wIMM-correlated", correlated},
                                                       {"nIMM-tuned", tuned_normal.spec}}) {
      c.filters.push_back(name);
      c.scores.push_back(trainer::wimm::score_tracking(spec, one_case.tracks, sensor));
    }
    judge_case(r, c);
    r.cases.push_back(std::move(c));
  }
  // The 2-D filter a tracking engineer would set for the regime, on the same plots.
  r.versus_bar = compare_with_bar(
      "wIMM", [&] { return std::make_unique<WimmFilter>(trained); }, trained.track_options(),
      r.regimes.trained.regime, data, sensor, options.common.classical);
  if (r.versus_bar && r.versus_bar->verdict != "beats") r.findings.push_back(r.versus_bar->summary);
  return r;
}

int report_wimm(const WimmResult& r, const WimmOptions& options) {
  const datasets::Regime& regime = r.regimes.evaluated.regime;
  const datasets::TrackSet& data = r.tracks;
  std::cout << "wimm: " << r.regimes.describe() << "\n  test split: " << data.tracks.size()
            << " tracks x " << data.scans << " scans, seed " << r.seed
            << "\n  wIMM: " << r.parameters.at("wIMM")
            << "\n  nIMM-tuned: " << r.parameters.at("nIMM-tuned") << "\n";
  if (r.on_tuned) {
    std::cout
        << "  the wIMM's fusion is learned on top of its nIMM tuned on the training split (q1 "
        << r.trained_q1 << ", P(CV→CV) " << r.trained_stay << "); nIMM is the seed's (q1 "
        << r.nimm_q1 << ", P(CV→CV) " << r.nimm_stay << ")"
        << (r.learned_part_on ? ""
                              : "; its learned part is switched off: the fusion did not beat that "
                                "nIMM on the training and validation splits, so the model is it")
        << "\n";
  }
  const std::filesystem::path& out = options.common.out;
  if (!data.has_truth) {  // recorded plots without truth: judged by their prediction
    std::cout << "\n";
    return plots_only_report("wimm", r.filters, "wIMM", {"nIMM", "nIMM-tuned"},
                             {"wimm", r.model, regime.name, regime.digest, r.seed, r.runs()}, out);
  }
  std::filesystem::create_directories(out);
  nlohmann::json metrics, details;
  bool plotted = true;
  std::vector<CaseHeadline> headline_cases;
  for (const WimmCase& c : r.cases) {
    plotted &= report_case(r, c, metrics, details, out);
    const TrackingScore& w = c.scores[1];
    headline_cases.push_back(
        {c.name, w.track_azimuth_settled, w.track_position_settled, w.run_position_nees});
  }
  if (r.regimes.evaluated.find("nIMM", regime.scripted() ? regime.case_name(0) : "",
                               "azimuth_rmse")) {
    std::cout << "\nThe paper's absolute azimuth errors (0.0249 rad = 1.43°) cannot come from "
                 "plots with σ_θ = 0.5° (0.0087 rad): they exceed the raw plot error. Compare the "
                 "ratios.\n";
  }
  print_recorded_prediction(data, r.filters, "wIMM");
  details["versus_classical_bar"] = nullptr;
  if (r.versus_bar) {
    print_bar_comparison(*r.versus_bar);
    details["versus_classical_bar"] = r.versus_bar->json();
  }
  std::cout << "\nGates (settled azimuth "
            << (paper_scenario(regime) ? "below the nIMM's (the seed's scenario)"
                                       : "not above the nIMM's (a regime beyond the seed)")
            << ", position not above it, beyond the uncertainty): "
            << (r.failures.empty() ? "passed" : "FAILED") << '\n';
  for (const auto& failure : r.failures) std::cout << "  - " << failure << '\n';
  print_findings(r.findings);
  const HeadlineRuns evaluated{"wimm", r.model, regime.name, regime.digest, r.seed, r.runs()};
  write_metrics(out, evaluated, wimm_definitions(std::string(datasets::to_string(regime.units))),
                metrics);
  write_headline(out, evaluated, wimm_headline(headline_cases));
  details["parameters"] = r.parameters;
  details["regime"] = {{"name", regime.name},
                       {"model_regime", r.regimes.trained.regime.name},
                       {"off_training", r.regimes.off_training()}};
  details["runs"] = data.tracks.size();
  details["seed"] = r.seed;
  details["gate_failures"] = r.failures;
  details["findings"] = r.findings;
  trainer::write_json_atomically(out / "details.json", details);
  return finish_report(out, plotted, r.failures, /*failures_printed=*/true, r.findings);
}

int run_wimm(const WimmOptions& options) { return report_wimm(evaluate_wimm(options), options); }

}  // namespace imm::evaluation
