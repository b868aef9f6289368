// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The experiments of `imm-eval`, callable from any program: each is an options struct (its
/// defaults are the command's) and a function that runs it. Every experiment but regression is
/// split in two: `evaluate_*` computes every figure and writes nothing, returning a typed result;
/// `report_*` prints the report (which `imm-eval` keeps as report.md) and writes metrics.json,
/// details.json, headline.json and the plots into the options' `out`. `run_*` is the two in turn,
/// and returns the command's exit code (support/exit_codes.hpp). The command line itself lives in
/// tools/imm-eval.
///
///   imm::evaluation::GaImmOptions options;
///   options.common.model = "models/ga_fuzzy_imm.h5";
///   options.common.runs = 50;
///   const imm::evaluation::GaImmResult result = imm::evaluation::evaluate_ga_imm(options);
///   const imm::evaluation::FilterOutcome& ours = result.filter("GA-IMM");  // ζ_p, ζ_v, NEES …

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "imm/datasets/track.hpp"
#include "imm/evaluation/classical_bar.hpp"
#include "imm/evaluation/consistency.hpp"
#include "imm/evaluation/evaluation_gates.hpp"
#include "imm/evaluation/experiment.hpp"
#include "imm/evaluation/fcm_imm_outcome.hpp"
#include "imm/evaluation/fimm_outcome.hpp"
#include "imm/evaluation/headline.hpp"
#include "imm/evaluation/input_estimator_outcome.hpp"
#include "imm/evaluation/monte_carlo.hpp"
#include "imm/evaluation/multi_target.hpp"
#include "imm/evaluation/tracker_choice.hpp"
#include "imm/evaluation/uncertainty.hpp"
#include "imm/trainer/wimm/tracking_score.hpp"

namespace imm::evaluation {

/// What every experiment's result carries: the evaluation's identity, the filters' Monte Carlo
/// outcomes on the same test tracks, the verdicts and the exit code they give.
struct ExperimentResult {
  std::string experiment;  ///< "ga-imm", "plain-imm", …
  std::filesystem::path model;
  EvaluationRegimes regimes;  ///< where the tracks come from, and the model's own regime
  std::uint64_t seed = 1;
  /// The test tracks every filter ran on (truth, plots, times; has_truth false: recorded plots
  /// judged by their prediction).
  datasets::TrackSet tracks;
  std::vector<FilterOutcome> filters;
  /// Gate failures (something is broken) and findings (a tuned baseline not beaten).
  std::vector<std::string> failures, findings;

  /// Sets the experiment's name, its model file (common.model_path()) and the seed.
  void start(std::string name, const CommonOptions& common);
  /// start(), and the regimes: the one the model was trained on (recorded in `model`, the model
  /// file's provenance) and the one it is evaluated on (--regime, else the same).
  void start(std::string name, const CommonOptions& common, const io::Provenance& model);
  /// The number of test tracks.
  [[nodiscard]] int runs() const { return static_cast<int>(tracks.tracks.size()); }
  /// The outcome of the filter named `name`; std::out_of_range naming it otherwise.
  [[nodiscard]] const FilterOutcome& filter(const std::string& name) const;
  /// kEvaluationGateFailed when a gate failed, else kFindings when there are findings, else 0.
  [[nodiscard]] int exit_code() const;
};

/// A learned filter's differences to another filter on the same runs (paired bootstrap, 95 %):
/// ours − theirs in ζ_p and ζ_v (negative: ours is better).
struct ZetaDifference {
  Difference zeta_p, zeta_v;
};

// --- plain-imm --------------------------------------------------------------------------------

/// `imm-eval plain-imm`: a plain IMM model against each of its modes alone (and the classical
/// bar), on a regime's test split or a stored data set.
struct PlainImmOptions {
  CommonOptions common = CommonOptions::defaults("cv3_imm", "reports/plain-imm");
  std::string data;  ///< a stored data-set file (imm-data tracks) instead of drawing the test split
};

/// The plain-imm experiment's figures. The filters: the IMM (named after its file), then each
/// mode alone ("KF <mode>").
struct PlainImmResult : ExperimentResult {
  std::string source;  ///< where the tracks come from (a regime's split or a data-set file)
  std::string length;  ///< the tracks' length unit
  /// A plain IMM with learned noise schedules (imm-train schedule) on its regime: judged against
  /// the classical bar its schedules were learned on (`regimes` set only then).
  bool scheduled = false;
  std::map<std::string, ZetaDifference> imm_minus;  ///< the IMM − each mode alone
  std::optional<BarComparison> versus_bar;          ///< a scheduled IMM against the bar
};

[[nodiscard]] PlainImmResult evaluate_plain_imm(const PlainImmOptions& options);
/// Prints and writes the report of `result` into options.common.out; returns the exit code.
int report_plain_imm(const PlainImmResult& result, const PlainImmOptions& options);
int run_plain_imm(const PlainImmOptions& options);

// --- ga-imm -----------------------------------------------------------------------------------

/// `imm-eval ga-imm`: seed 000's Table 3 (ga_imm_experiment.cpp says what runs and what is gated).
struct GaImmOptions {
  CommonOptions common = CommonOptions::defaults("ga_fuzzy_imm", "reports/ga-imm");
  std::string paper_model = "reference/ga_fuzzy_imm_paper.h5";  ///< in common.models
};

/// How far a fuzzy filter's q_j(k) moves: percentiles over scans, runs and axes.
struct ProcessNoiseSpread {
  std::string filter, mode;
  double p01 = 0.0, p50 = 0.0, p99 = 0.0;
};

/// The ga-imm experiment's figures. The filters: AIMM3, AIMM5, AIMM-tuned, IMM-tuned, the
/// classical bar (when tuned), GA-IMM-paper (when it applies), GA-IMM.
struct GaImmResult : ExperimentResult {
  std::map<std::string, std::string> tuned;            ///< each tuned baseline's parameters
  std::map<std::string, double> training_scores;       ///< ζ_p + ζ_v on the training split
  std::map<std::string, ZetaDifference> ga_imm_minus;  ///< GA-IMM − each other filter
  std::vector<ProcessNoiseSpread> spreads;
  std::string paper_note;   ///< why GA-IMM-paper was left out, if it was
  bool paper = false;       ///< GA-IMM-paper ran
  bool paper_file = false;  ///< the paper's model file exists
  std::filesystem::path paper_path;
  bool learned_part_on = true;    ///< training.learned_part_on of the model
  bool paper_scenario = false;    ///< the regime is one of the seed's own scenarios
  std::string against_imm_tuned;  ///< "beats", "ties" or "loses to"
  std::string against_bar;        ///< the same against the classical bar, with its figures
};

[[nodiscard]] GaImmResult evaluate_ga_imm(const GaImmOptions& options);
int report_ga_imm(const GaImmResult& result, const GaImmOptions& options);
int run_ga_imm(const GaImmOptions& options);

// --- the other experiments (printing and writing as they run) ---------------------------------

// --- input-estimator --------------------------------------------------------------------------

/// `imm-eval input-estimator`: seed 001's Tables 1–2 (mlp_input_estimator_experiment.cpp says
/// what runs and what is gated).
struct InputEstimatorOptions {
  CommonOptions common = CommonOptions::defaults("mlp_input_estimator", "reports/input-estimator");
};

/// One case's comparisons: the corrected KF − the CV KF in the innovation, position and velocity
/// MSE; − IMM-tuned in position and velocity, with its verdict; both filters' consistency.
struct InputEstimatorVerdicts {
  std::string name;
  std::array<Difference, 3> corrected_minus_cv;
  std::array<Difference, 2> corrected_minus_imm_tuned;
  std::string versus_imm_tuned;  ///< "beats", "ties" or "loses to"
  FilterConsistency corrected, imm_tuned;
};

/// The input-estimator experiment's figures: per case (`cases`, and `verdicts` for those with
/// runs); `filters` holds the plot-prediction outcomes (CV KF, IMM-tuned, corrected KF) where the
/// tracks are recorded.
struct InputEstimatorResult : ExperimentResult {
  AxisCvImmSpec imm_tuned;  ///< tuned on the model's training split
  int imm_tuned_evaluations = 0;
  std::vector<InputEstimatorCase> cases;
  std::vector<InputEstimatorVerdicts> verdicts;
  int wins = 0, cells = 0;          ///< cells where the corrected KF beats the CV KF, of all
  std::vector<std::string> losses;  ///< the cells where it does not
  bool passed = false;              ///< the gate: wins in at least 90 % of the cells
  std::optional<BarComparison> versus_bar;
  Eigen::MatrixXd training_loss;  ///< the model's training curve (epoch, training, validation)
};

[[nodiscard]] InputEstimatorResult evaluate_input_estimator(const InputEstimatorOptions& options);
int report_input_estimator(const InputEstimatorResult& result,
                           const InputEstimatorOptions& options);
int run_input_estimator(const InputEstimatorOptions& options);

// --- wimm -------------------------------------------------------------------------------------

/// `imm-eval wimm`: seed 004's Table 2 (wimm_experiment.cpp says what runs and what is gated).
struct WimmOptions {
  CommonOptions common = CommonOptions::defaults("wimm", "reports/wimm");
};

/// One case of the regime (seed 004's scenario 1 or 2, or all tracks of a random regime): each
/// filter's tracking score on the case's tracks.
struct WimmCase {
  int index = 0;
  std::string name;
  int runs = 0;
  /// nIMM, wIMM, wIMM-seed, wIMM-correlated, nIMM-tuned, and their scores in that order.
  std::vector<std::string> filters;
  std::vector<trainer::wimm::TrackingScore> scores;
  /// Each filter's settled RMS azimuth error minus the nIMM's (the first: against itself).
  std::vector<Difference> versus_nimm;
  std::vector<FilterConsistency> consistency;  ///< each filter's NEES and NIS
};

/// The wimm experiment's figures. `filters` holds the plot-prediction outcomes (wIMM, nIMM,
/// wIMM-seed, nIMM-tuned) where the tracks are recorded; the errors are per case.
struct WimmResult : ExperimentResult {
  std::map<std::string, std::string> parameters;  ///< the wIMM's and nIMM-tuned's
  bool on_tuned = false;                          ///< the fusion was learned on top of a tuned nIMM
  bool learned_part_on = true;
  double trained_q1 = 0.0, trained_stay = 0.0;  ///< the model's nIMM: q₁ and P(CV→CV)
  double nimm_q1 = 0.0, nimm_stay = 0.0;        ///< the seed's nIMM it is compared with
  int settled = 0;                              ///< the first settled scan
  std::vector<WimmCase> cases;
  std::optional<BarComparison> versus_bar;
};

[[nodiscard]] WimmResult evaluate_wimm(const WimmOptions& options);
int report_wimm(const WimmResult& result, const WimmOptions& options);
int run_wimm(const WimmOptions& options);

// --- fcm-imm ----------------------------------------------------------------------------------

/// `imm-eval fcm-imm`: seed 003's Fig. 5–8 (fcm_imm_experiment.cpp says what runs and what is
/// gated).
struct FcmImmOptions {
  CommonOptions common = CommonOptions::defaults("fcm_imm", "reports/fcm-imm");
};

/// The fcm-imm experiment's figures. `outcomes`: KF, AIMM, IMM-tuned, FCM-IMM, FCM-IMM-const;
/// `filters` holds their plot-prediction outcomes where the tracks are recorded.
struct FcmImmResult : ExperimentResult {
  std::string tuning_note;    ///< how the baselines' search was found, when not from the model
  std::string tuning_regime;  ///< the regime whose training split tuned the baselines
  std::map<std::string, std::string> parameters;     ///< each filter's tuned or fitted settings
  std::map<std::string, double> training_objective;  ///< the fitting objective J, training split
  std::vector<FcmImmOutcome> outcomes;
  /// FCM-IMM − each other filter in the four figures (kFcmImmFigures).
  std::map<std::string, std::array<Difference, 4>> fcm_imm_minus;
  bool learned_part_on = true;
  bool paper_scenario = false;
  std::optional<BarComparison> versus_bar;

  /// The outcome named `name`; std::out_of_range otherwise.
  [[nodiscard]] const FcmImmOutcome& outcome(const std::string& name) const;
};

[[nodiscard]] FcmImmResult evaluate_fcm_imm(const FcmImmOptions& options);
int report_fcm_imm(const FcmImmResult& result, const FcmImmOptions& options);
int run_fcm_imm(const FcmImmOptions& options);

// --- fimm -------------------------------------------------------------------------------------

/// `imm-eval fimm`: seed 002's Table 1 (fimm_experiment.cpp says what runs and what is gated).
struct FimmOptions {
  CommonOptions common = CommonOptions::defaults("tsk_range_sensor", "reports/fimm");
  std::filesystem::path config = "configs/tsk_range_sensor.toml";  ///< the FIMM's settings
  std::string gate_on = "ekf";  ///< "ekf": gate the FIMM (EKF); "best": the better of EKF, IEKF
};

/// One case of the regime (one plot noise): the IMM, the FIMM (EKF) and the FIMM (IEKF).
struct FimmCase {
  int index = 0;
  std::string name;
  int runs = 0;
  double measurement_variance = 0.0;  ///< R of the case's plots (z1)
  FimmOutcome imm, fimm, iekf;
  Difference fimm_minus_imm, iekf_minus_imm;  ///< in position MSE
};

/// The fimm experiment's figures, per case; `filters` holds the plot-prediction outcomes (FIMM
/// (EKF), FIMM (IEKF), IMM) where the tracks are recorded.
struct FimmResult : ExperimentResult {
  std::string settings;  ///< the FIMM's settings, as the report states them
  std::string gate_on;
  std::vector<FimmCase> cases;
  /// The fitted sensor against the true one over the model's box: η, the true η_m along the
  /// road, the model's z2 there, the true ξ_m in the start's lane, the model's z1 there.
  Eigen::MatrixXd sensor_curve;
};

[[nodiscard]] FimmResult evaluate_fimm(const FimmOptions& options);
int report_fimm(const FimmResult& result, const FimmOptions& options);
int run_fimm(const FimmOptions& options);

/// `imm-eval rank`: the regime's tracker chosen among its tuned baselines and learned models.
struct RankOptions {
  /// The regime's tuned classical filters; the best on the test tracks is the bar.
  std::vector<std::filesystem::path> baselines;
  std::vector<std::filesystem::path> candidates;
  /// Report folders of the candidates' own experiments (imm-eval <experiment> --out).
  std::vector<std::filesystem::path> evaluations;
  std::optional<std::filesystem::path> regime;
  std::optional<int> runs;
  std::uint64_t seed = 1;
  std::filesystem::path out = "reports/rank";
  std::optional<std::filesystem::path> ship;
  /// Ship the winner as it is, without the covariance calibration fitted on its training split.
  bool raw_ship = false;
};

/// The rank experiment's figures: every file's Monte Carlo outcome (`filters`, baselines first,
/// in the order given), its place in the ranking and the choice. report_rank writes tracker.json
/// and, with RankOptions::ship, ships the winner.
struct RankResult : ExperimentResult {
  datasets::Regime regime;
  std::vector<std::filesystem::path> files;  ///< the baselines, then the candidates
  std::vector<std::string> kinds;            ///< each file's model_kind
  std::size_t classical = 0;                 ///< how many of the files are baselines
  std::size_t bar = 0;                       ///< the best baseline: every candidate faces it
  std::vector<RankedFilter> ranked;
  std::vector<GateStanding> standings;  ///< each candidate's own experiment's gates
  std::size_t evaluations = 0;          ///< evaluation folders given
  TrackerChoice choice;
  /// The position RMSE where the truth manoeuvres, and its difference from the bar's (`maneuvers`:
  /// there is truth and the bar's figure is finite).
  std::vector<double> maneuver_rmse;
  std::vector<Difference> maneuver_versus_bar;
  bool maneuvers = false;

  /// Whether file i is a candidate the choice considered (not held out by its gates or its
  /// consistency).
  [[nodiscard]] bool eligible(std::size_t i) const;
};

[[nodiscard]] RankResult evaluate_rank(const RankOptions& options);
int report_rank(const RankResult& result, const RankOptions& options);
int run_rank(const RankOptions& options);

/// `imm-eval multi-target`: run_multi_target over every condition, a table each.
struct MultiTargetOptions {
  std::vector<std::filesystem::path> models;
  std::optional<std::filesystem::path> regime;
  MultiTargetSettings settings;
  /// The conditions: every detection probability with every clutter density (none given: the
  /// regime's [scene]), and the targets per scene (likewise).
  std::vector<double> detection_probabilities, clutter_densities;
  std::optional<int> targets;
  std::filesystem::path out = "reports/multi-target";
};

/// The multi-target experiment's figures: every condition (detection probability × clutter
/// density) with its settings and the models' figures on the same scenes.
struct MultiTargetConditions {
  datasets::Regime regime;
  struct Condition {
    MultiTargetSettings settings;
    MultiTargetResult figures;
  };
  std::vector<Condition> conditions;
};

/// Every condition's scenes, run (InvalidParameter naming the field for a bad setting, before
/// any scene runs).
[[nodiscard]] MultiTargetConditions evaluate_multi_target(const MultiTargetOptions& options);
/// A table per condition on stdout and metrics.json ("conditions") in options.out.
int report_multi_target(const MultiTargetConditions& result, const MultiTargetOptions& options);
int run_multi_target_experiment(const MultiTargetOptions& options);

/// `imm-eval regression`: a candidate's headline metrics against the shipped model's.
struct RegressionOptions {
  std::filesystem::path candidate, shipped;  ///< headline.json files or their folders
  std::optional<std::filesystem::path> out;  ///< folder for regression.json
  std::vector<MarginRule> margins;
};
int run_regression(const RegressionOptions& options);

}  // namespace imm::evaluation
