// SPDX-License-Identifier: Apache-2.0
// `imm-eval rank`: the regime's tracker. The tuned classical baseline (`imm-train baseline`) and
// every learned model trained for the regime run on the same test tracks through imm::load_filter
// — exactly as a tracking application would run them — and are ranked by seed 000's ζ_p + ζ_v,
// each with its difference from the baseline and the 95 % paired-bootstrap interval. The winner is
// chosen by the rule of tracker_choice.hpp (a learned model must beat the baseline beyond the
// interval) and, with --ship, written as the regime's tracker file. A learned model that does not
// beat the baseline is a finding (exit 7), not a failure: the baseline is shipped in its place.
// A learned model is eligible only when an evaluation of that very file (--evaluations: report
// folders of `imm-eval <experiment>`) passed its own experiment's gates; one that failed them, or
// that no evaluation given checked, is ranked but held out (a finding).

#include <cmath>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "imm/datasets/sha256.hpp"
#include "imm/evaluation/evaluation_gates.hpp"
#include "imm/evaluation/evaluation_report.hpp"
#include "imm/evaluation/experiment.hpp"
#include "imm/evaluation/experiments.hpp"
#include "imm/evaluation/monte_carlo.hpp"
#include "imm/evaluation/report.hpp"
#include "imm/evaluation/tracker_choice.hpp"
#include "imm/io/temporary_files.hpp"
#include "imm/load.hpp"
#include "imm/trainer/model_files/calibration.hpp"
#include "imm/trainer/model_files/envelope.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::evaluation {
namespace {

// The shipped file's consistency on the test tracks, for tracker.json.
nlohmann::json consistency_of(const FilterOutcome& outcome) {
  nlohmann::json c = {{"nis", outcome.nis_consistency.average},
                      {"nis_inside", outcome.nis_consistency.inside}};
  if (outcome.has_truth) {
    c["position_nees"] = outcome.position_consistency.average;
    c["position_nees_inside"] = outcome.position_consistency.inside;
  }
  return c;
}

// Writes the winner to `ship`: with its covariance calibration (fitted on the regime's training
// split, calibrated_filter.hpp) and the envelope recalibrated for the calibrated NIS, unless
// `raw`. Returns what tracker.json records of it: the calibration and its test-split consistency.
nlohmann::json ship_winner(const std::filesystem::path& winner, const std::filesystem::path& ship,
                           bool raw, const FilterOutcome& as_ranked, const datasets::TrackSet& data,
                           const Eigen::Vector2d& sensor) {
  nlohmann::json shipped = {{"file", ship.string()}, {"uncalibrated", consistency_of(as_ranked)}};
  if (raw) {
    trainer::copy_atomically(winner, ship);
    return shipped;
  }
  // Calibrated in a temporary beside the target and then moved over it in one rename: under the
  // tracker's name there is the old file or the whole new one, never one without its calibration.
  const std::filesystem::path work = io::temporary_beside(ship, 1U);
  trainer::copy_atomically(winner, work);
  const trainer::CalibrationFit fit = trainer::fit_calibration(winner);
  shipped["calibration"] = trainer::describe(fit);
  std::cout << "  " << trainer::describe(fit) << '\n';
  if (fit.fitted) {
    trainer::store_calibration(work, fit.calibration);
    std::cout << "  " << trainer::describe(trainer::calibrate_and_store_envelope(work)) << '\n';
  }
  trainer::move_atomically(work, ship);
  if (!fit.fitted) return shipped;
  const FilterMaker maker = load_filter_maker(ship);
  shipped["calibrated"] = consistency_of(
      run_monte_carlo(ship.stem().string(), maker.make, maker.options, data, {}, sensor));
  return shipped;
}

// The criteria of the verdict: ζ_p and ζ_v against truth, or — on recorded plots without it —
// the predictive NLL per plot and the innovation RMS (FilterOutcome::plot_headline), of `own`
// against `bar` (the best classical filter; `is_bar` for the bar itself).
RankedFilter ranked_filter(const std::filesystem::path& file, const std::string& kind,
                           const FilterOutcome& own, const FilterOutcome& bar, bool is_bar,
                           bool classical, int runs) {
  RankedFilter r;
  r.name = file.stem().string();
  r.kind = kind;
  r.baseline = is_bar;
  r.classical = classical && !is_bar;
  r.position_rmse = own.position_rmse;
  r.velocity_rmse = own.velocity_rmse;
  // Without truth the consistency is the NIS's.
  const ConsistencySummary& consistency =
      own.has_truth ? own.position_consistency : own.nis_consistency;
  r.consistency = consistency.verdict();
  r.position_nees = consistency.average;
  r.scans_inside = consistency.inside;
  r.nis_inside = own.nis_consistency.inside;
  r.scans = consistency.scans;
  r.nis_scans = own.nis_consistency.scans;
  if (own.has_truth) {
    r.zeta_p = own.zeta_p;
    r.zeta_v = own.zeta_v;
    if (!r.baseline) {
      r.versus_baseline_p = paired_difference(runs, own.zeta_p_statistic(), bar.zeta_p_statistic());
      r.versus_baseline_v = paired_difference(runs, own.zeta_v_statistic(), bar.zeta_v_statistic());
    }
    return r;
  }
  const std::vector<HeadlineMetric> metrics = own.plot_headline();
  const std::vector<HeadlineMetric> base = bar.plot_headline();
  r.criteria = {"predictive NLL", "innovation RMS"};
  r.zeta_p = metrics[0].value();
  r.zeta_v = metrics[2].value();
  r.score = r.zeta_p;
  if (!r.baseline) {
    r.versus_baseline_p = paired_difference(runs, metrics[0].statistic(), base[0].statistic());
    r.versus_baseline_v = paired_difference(runs, metrics[2].statistic(), base[2].statistic());
  }
  return r;
}

// What orders filters: ζ_p + ζ_v with truth, the predictive NLL per plot without.
double order_score(const FilterOutcome& outcome) {
  return outcome.has_truth ? outcome.zeta_p + outcome.zeta_v : outcome.plot_headline()[0].value();
}

// The ranking's table on stdout.
void print_ranking(const RankResult& r) {
  const std::vector<RankedFilter>& ranked = r.ranked;
  const TrackerChoice& choice = r.choice;
  const datasets::TrackSet& data = r.tracks;
  const std::string length(datasets::to_string(r.regime.units));
  const std::array<std::string, 2>& criteria = ranked.front().criteria;
  std::vector<std::vector<std::string>> rows;
  for (std::size_t place = 0; place < choice.order.size(); ++place) {
    const std::size_t i = choice.order[place];
    const RankedFilter& f = ranked[i];
    rows.push_back({std::to_string(place + 1),
                    f.name + (f.baseline                  ? " (the classical bar)"
                              : f.classical               ? " (classical)"
                              : !r.choice.held[i].empty() ? " (held out)"
                                                          : ""),
                    f.kind, cell(f.zeta_p), cell(f.zeta_v),
                    f.baseline ? "–" : f.versus_baseline_p.text(),
                    f.baseline ? "–" : f.versus_baseline_v.text(), verdict_against_baseline(f),
                    data.has_truth ? cell(f.position_rmse) : "–",
                    data.has_truth ? cell(f.velocity_rmse, 5) : "–"});
    if (r.maneuvers) {
      rows.back().push_back(cell(r.maneuver_rmse[i]));
      rows.back().push_back(i == r.bar ? "–" : r.maneuver_versus_bar[i].text(2));
    }
  }
  std::vector<std::string> headers{"place",
                                   "filter",
                                   "kind",
                                   criteria[0],
                                   criteria[1],
                                   "this − bar " + criteria[0] + " [95 %]",
                                   "this − bar " + criteria[1] + " [95 %]",
                                   "against the bar",
                                   "position RMSE (" + length + ")",
                                   "velocity RMSE (" + length + "/s)"};
  if (r.maneuvers) {
    headers.push_back("position RMSE in manoeuvres (" + length + ")");
    headers.push_back("this − bar in manoeuvres [95 %]");
  }
  std::cout << "rank: regime " << r.regime.name << " test split, seed " << r.seed << ", "
            << r.runs() << " tracks x " << data.scans << " scans\n\n"
            << markdown_table(headers, rows) << '\n'
            << kDifferenceConvention << ' ' << kVerdictRule
            << "\nThe classical bar: " << ranked[r.bar].name << " (" << ranked[r.bar].kind
            << "), the best of the regime's tuned classical filters on these tracks ("
            << r.classical << " given)."
            << (r.maneuvers ? "\nIn manoeuvres: the position RMSE over the scans where the truth "
                              "manoeuvres (a commanded acceleration or a turn acts), and its "
                              "difference from the bar; reported beside the verdict, not in it."
                            : "")
            << (data.has_truth
                    ? "\nThe rule: a learned model is the tracker only when it beats the "
                      "classical bar; among those that do, the lowest ζ_p + ζ_v.\n\n"
                      "Consistency:\n\n"
                    : "\nThe tracks have no truth: the filters are judged by how well they "
                      "predict the plots — the predictive NLL −log p(z | Z^(k−1)) per plot and "
                      "the RMS of the innovation ‖z − ẑ‖ (position errors are not known; their "
                      "columns are 0). The rule: a learned model is the tracker only when it "
                      "beats the classical bar; among those that do, the lowest NLL.\n\n"
                      "Consistency (NIS only):\n\n")
            << consistency_table(r.filters) << "\nTracker: " << ranked[choice.winner].name << " — "
            << choice.reason << '\n';
}

// tracker.json's content (metrics.json's results) without the shipping.
nlohmann::json tracker_json(const RankResult& r) {
  const std::vector<RankedFilter>& ranked = r.ranked;
  const datasets::TrackSet& data = r.tracks;
  nlohmann::json results;
  results["tracker"] = ranked[r.choice.winner].name;
  results["tracker_file"] = r.files[r.choice.winner].string();
  results["reason"] = r.choice.reason;
  results["rule"] =
      data.has_truth
          ? "a learned model is the tracker only when it beats the classical bar — the best of "
            "the regime's tuned classical filters (verdict over ζ_p and ζ_v); among those that "
            "do, the lowest ζ_p + ζ_v; otherwise the bar"
          : "no truth: a learned model is the tracker only when it beats the classical bar — the "
            "best of the regime's tuned classical filters (verdict over the predictive NLL per "
            "plot and the innovation RMS); among those that do, the lowest NLL; otherwise the bar";
  results["bar"] = ranked[r.bar].name;
  results["bar_file"] = r.files[r.bar].string();
  for (std::size_t i = 0; i < r.classical; ++i) results["classical"].push_back(ranked[i].name);
  results["truth"] = data.has_truth;
  for (std::size_t place = 0; place < r.choice.order.size(); ++place) {
    const std::size_t i = r.choice.order[place];
    const RankedFilter& f = ranked[i];
    const std::vector<HeadlineMetric> plots = r.filters[i].plot_headline();
    nlohmann::json row = {{"place", place + 1},
                          {"filter", f.name},
                          {"file", r.files[i].string()},
                          {"kind", f.kind},
                          {"baseline", f.baseline},
                          {"classical", i < r.classical},
                          {"position_rmse", f.position_rmse},
                          {"velocity_rmse", f.velocity_rmse},
                          {"verdict", verdict_against_baseline(f)},
                          {"own_gates", i < r.classical ? "—" : r.standings[i].text},
                          {"eligible", r.eligible(i)},
                          {"nis_inside", f.nis_inside},
                          {"predictive_nll", plots[0].value()},
                          {"innovation_rms", plots[2].value()},
                          {"position_nees", r.filters[i].position_consistency.average},
                          {"nis", r.filters[i].nis_consistency.average}};
    if (!f.baseline) {
      const char* first = data.has_truth ? "zeta_p" : "predictive_nll";
      const char* second = data.has_truth ? "zeta_v" : "innovation_rms";
      row["versus_baseline"] = {
          {first,
           {f.versus_baseline_p.estimate, f.versus_baseline_p.lower, f.versus_baseline_p.upper}},
          {second,
           {f.versus_baseline_v.estimate, f.versus_baseline_v.lower, f.versus_baseline_v.upper}}};
    }
    if (data.has_truth) row["zeta_p"] = f.zeta_p, row["zeta_v"] = f.zeta_v;
    if (r.maneuvers) {
      row["position_rmse_maneuvering"] = r.maneuver_rmse[i];
      if (i != r.bar) {
        const Difference& d = r.maneuver_versus_bar[i];
        row["versus_baseline"]["position_rmse_maneuvering"] = {d.estimate, d.lower, d.upper};
      }
    }
    results["ranking"].push_back(row);
  }
  results["findings"] = r.findings;
  return results;
}

}  // namespace

bool RankResult::eligible(std::size_t i) const { return i >= classical && choice.held[i].empty(); }

RankResult evaluate_rank(const RankOptions& options) {
  RankResult r;
  r.experiment = "rank";
  r.seed = options.seed;
  const datasets::RegimeFile regime =
      load_regime_option(options.regime.value_or(options.baselines.front()));
  r.regime = regime.regime;
  r.model = options.baselines.front();
  CommonOptions common;
  common.runs = options.runs;
  common.seed = options.seed;
  r.tracks = test_tracks(regime.regime, common);
  const datasets::TrackSet& data = r.tracks;
  const int runs = r.runs();

  r.files = options.baselines;
  r.files.insert(r.files.end(), options.candidates.begin(), options.candidates.end());
  r.classical = options.baselines.size();
  std::vector<EvaluationGates> evaluations;
  for (const auto& folder : options.evaluations) {
    evaluations.push_back(read_evaluation_gates(folder));
  }
  r.evaluations = evaluations.size();
  for (const auto& file : r.files) {
    const FilterMaker maker = load_filter_maker(file);
    const EvaluationRegimes regimes = evaluation_regimes(regime, maker.provenance, file);
    if (regimes.off_training()) {
      const datasets::Regime& own = regimes.trained.regime;
      const datasets::Regime& here = regime.regime;
      const std::string where =
          here.file.empty() ? std::string("the regime recorded in ") + r.files.front().string()
                            : here.file;
      throw std::runtime_error(
          "model " + file.string() + ": " +
          (own.name == here.name
               ? "trained for another text of regime " + own.name + " than " + where + " (digest " +
                     own.digest.substr(0, 12) + " against " + here.digest.substr(0, 12) + ")"
               : "trained for regime " + own.name + ", not " + here.name + " (" + where + ")") +
          ": a regime's tracker is chosen among its own models");
    }
    r.filters.push_back(run_monte_carlo(file.stem().string(), maker.make, maker.options, data, {},
                                        regime.regime.sensor.position));
    r.kinds.push_back(maker.provenance.model_kind);
  }
  // The bar: the best of the classical filters on these tracks. Every learned model faces it.
  for (std::size_t i = 1; i < r.classical; ++i) {
    if (order_score(r.filters[i]) < order_score(r.filters[r.bar])) r.bar = i;
  }
  for (std::size_t i = 0; i < r.files.size(); ++i) {
    r.ranked.push_back(ranked_filter(r.files[i], r.kinds[i], r.filters[i], r.filters[r.bar],
                                     i == r.bar, i < r.classical, runs));
  }
  r.standings.resize(r.files.size());
  for (std::size_t i = r.classical; i < r.files.size(); ++i) {
    r.standings[i] = gate_standing(datasets::file_sha256_hex(r.files[i]), evaluations);
    if (r.standings[i].state != GateStanding::State::kPassed) {
      r.ranked[i].held_out = r.standings[i].text;
    }
  }
  r.choice = choose_tracker(r.ranked);
  // Where the motion models are put to the test: the position RMSE over the scans where the truth
  // manoeuvres, with each filter's difference from the bar (reported; the verdict is over ζ).
  r.maneuver_rmse.resize(r.files.size());
  r.maneuver_versus_bar.resize(r.files.size());
  const HeadlineMetric bar_maneuver = r.filters[r.bar].maneuver_position_rmse();
  for (std::size_t i = 0; i < r.files.size(); ++i) {
    const HeadlineMetric own = r.filters[i].maneuver_position_rmse();
    r.maneuver_rmse[i] = own.value();
    if (i != r.bar && data.has_truth) {
      r.maneuver_versus_bar[i] = paired_difference(runs, own.statistic(), bar_maneuver.statistic());
    }
  }
  r.maneuvers = data.has_truth && std::isfinite(r.maneuver_rmse[r.bar]);

  const std::array<std::string, 2>& criteria = r.ranked.front().criteria;
  for (const RankedFilter& f : r.ranked) {
    if (!f.baseline && !f.classical && verdict_against_baseline(f) != "beats") {
      r.findings.push_back(f.name + " " + verdict_against_baseline(f) + " the classical bar " +
                           r.ranked[r.bar].name + " (" + criteria[0] + " " +
                           f.versus_baseline_p.text() + ", " + criteria[1] + " " +
                           f.versus_baseline_v.text() + ")");
    }
    if (std::string flag = inconsistency_finding(f); !flag.empty()) {
      r.findings.push_back(std::move(flag));
    }
  }
  for (std::size_t i = r.classical; i < r.files.size(); ++i) {
    if (!r.eligible(i)) {
      r.findings.push_back(r.ranked[i].name + " is held out of the choice (" + r.choice.held[i] +
                           ")");
    }
  }
  return r;
}

int report_rank(const RankResult& r, const RankOptions& options) {
  print_ranking(r);
  std::cout << "\nThe learned models' own experiments' gates (eligible only when an evaluation of "
               "that very file passed them; "
            << r.evaluations << " evaluation folder(s) given):\n";
  for (std::size_t i = r.classical; i < r.files.size(); ++i) {
    std::cout << "  - " << r.ranked[i].name << ": " << r.standings[i].text << '\n';
  }
  print_findings(r.findings);

  const std::filesystem::path& out = options.out;
  std::filesystem::create_directories(out);
  nlohmann::json results = tracker_json(r);
  std::vector<ModelUse> more;
  for (std::size_t i = 1; i < r.files.size(); ++i) {
    more.push_back({i < r.classical ? "classical" : "candidate", r.files[i]});
  }
  const HeadlineRuns evaluated{"rank", r.model, r.regime.name, r.tracks.digest(), r.seed, r.runs()};
  write_metrics(out, evaluated,
                normalized_error_definitions(std::string(datasets::to_string(r.regime.units)),
                                             "baseline", true),
                results, more);
  if (options.ship) {
    const std::size_t winner = r.choice.winner;
    std::cout << "shipping " << r.files[winner].string() << " as " << options.ship->string()
              << '\n';
    results["shipped"] = ship_winner(r.files[winner], *options.ship, options.raw_ship,
                                     r.filters[winner], r.tracks, r.regime.sensor.position);
  }
  trainer::write_json_atomically(out / "tracker.json", results);
  std::cout << "\nwrote metrics.json and tracker.json in " << out.string() << '\n';
  return r.exit_code();
}

int run_rank(const RankOptions& options) { return report_rank(evaluate_rank(options), options); }

}  // namespace imm::evaluation
