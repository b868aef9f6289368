// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The nightly pipeline of `imm-train all --config configs/nightly.toml`: data sets, then models,
/// then tracking runs; every stage a process of its own (a crash or a failed gate is an exit
/// code, never a half-finished pipeline that looks green).
///
/// A model stage trains a *candidate* into the registry's staging folder (never over the shipped
/// file), evaluates it with every evaluation that names it, evaluates the shipped model of the
/// same name on the same test tracks, and promotes the candidate (imm/pipeline/registry.hpp) only
/// when its own quality gates pass and it is not worse than the shipped one beyond the Monte
/// Carlo uncertainty on the experiment's headline metrics (`imm-eval regression`). A failing
/// stage does not stop the stages after it. A stage whose inputs (tool binaries, arguments, the
/// bytes of every file it reads: config, regime, data, models) are unchanged since its last run is
/// skipped and reported as cached, with the outcome it had; `--force` reruns everything.
///
/// configs/nightly.toml:
///   registry = "models"   (optional: the folder of shipped models and models/manifest.json)
///   evaluations_page = "docs/evaluations.md"   (optional: rewritten every night from the report
///                                               of every evaluation stage)
///   [[data]]         name, command (tracks | sensor), regime, out, [split], [csv], [count], [seed]
///   [[models]]       name, command (an imm-train subcommand), config, out, [regime], [seed],
///                    [arguments]
///   [[tracks]]       filter, measurements, out
///   [[evaluations]]  experiment, model (a [[models]] name), out, [models], [regime], [runs],
///                    [seed], [arguments]
///   [[evaluations.known_failures]]  gate (a part of the failed gate's line), reason — a gate
///                    failure that is known and accepted (KnownFailure)
///   [regression]     [relative_margin], [absolute_margin], reason — the practical margin of the
///                    regression gate (`imm-eval regression`): a candidate is worse (or better)
///                    than the shipped model only beyond the interval *and* by more than
///                    max(relative_margin × |value|, absolute_margin)
///   [[regression.margins]]  metric (a part of the metric names it applies to), [relative_margin],
///                    [absolute_margin], reason — the margin of some metrics
///   [[trackers]]     name, baseline and/or baselines (the [[models]] names of the regime's tuned
///                    classical filters: `imm-train baseline`), candidates (the [[models]] names
///                    of the learned models of the same regime), out (the regime's tracker file,
///                    in the registry), report, [runs], [seed]
///
/// A tracker stage runs after every model stage: `imm-eval rank` over the *shipped* files of its
/// baselines and candidates (one never shipped is left out), the best classical filter is the bar
/// every candidate faces, and the winner is promoted as the regime's tracker under the stage's
/// name, its ranking in the manifest entry's metrics.
///
/// With `sweep`, the candidates that are not cached are all trained first, in one `imm-train sweep`
/// (under `launcher`: `mpirun -np 8`, `srun`), into the staging folder; then each model stage
/// evaluates and promotes its candidate as above.
///
/// A candidate that ties the shipped model — the same model but for its build and training date
/// (registry.hpp's model_difference), or no metric better or worse beyond the interval and the
/// margin while trained from the same config, regime and schema — is not promoted: the shipped
/// file stays byte for byte, so a night without news changes nothing in models/.
///
/// A candidate that is a model a person rolled back (`imm-train rollback`, recorded in the
/// manifest: Registry::rejection) is not promoted again until a person says so: `--force`, or
/// `imm-train promote`.
///
/// Exit codes of the run: 0 nothing failed and nothing was held back (findings — a learned model
/// that does not beat the baseline tuned on its regime, a known failure — are reported, not
/// failures), 3 a stage failed, 6 no stage failed but a candidate was held back by the regression
/// gate.

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace imm::pipeline {

/// A quality-gate failure of an evaluation that is known, measured and accepted, with its reason
/// ([[evaluations.known_failures]]): a paper's claim the product does not reproduce against a
/// baseline stronger than the paper's, say. When every failed line of an evaluation's gates
/// contains the `gate` of one of its known failures, the evaluation is a finding, not a failure:
/// the candidate goes on to the regression gate like any other, and the morning report shows the
/// failed lines with the reason. Any other failed line fails the stage as before; a known failure
/// that no longer happens is reported as news (remove the entry).
struct KnownFailure {
  std::string gate;    ///< a part of the gate's failure line ("pos_rmse_maneuver is above KF's")
  std::string reason;  ///< why it is accepted: the measured cause (required)
  /// Whether a failed gate's line is this failure (it contains `gate`).
  [[nodiscard]] bool accepts(std::string_view line) const {
    return line.find(gate) != std::string_view::npos;
  }
};

/// A file or folder a stage reads besides its tool and the texts of its arguments, declared where
/// the plan builds the stage: the stage cache digests exactly these (stage_cache.hpp).
struct StageInput {
  enum class Kind {
    /// A file's bytes, when it exists (a recorded regime's: and those of its track set).
    kFile,
    /// A trainer config's bytes and those of the regime it names (and of that regime's set).
    kTrainerConfig,
    /// An import's recordings: a folder's files by name, or one file.
    kRecordings,
    /// An evaluation's model folder: its model files other than the one it evaluates (a model
    /// of the plan by the digest of the stage that writes it).
    kModelFolder,
    /// A candidate's evaluation folder: its verdict (metrics.json, report.md), read afresh.
    kVerdicts,
  };
  Kind kind = Kind::kFile;
  std::filesystem::path path;
};

struct NightlyStage {
  std::string kind;        ///< "data", "model", "track", "evaluation", "tracker"
  std::string name;        ///< for the log and the report
  std::string executable;  ///< imm-data, imm-train, imm-track, imm-eval
  std::vector<std::string> arguments;
  std::vector<std::filesystem::path> output_folders;  ///< created before the stage runs
  std::filesystem::path out;     ///< the model file (model), the report folder (evaluation), …
  std::string model;             ///< evaluation: the [[models]] stage it evaluates
  std::filesystem::path report;  ///< tracker: the ranking's report folder
  bool has_regime = false;       ///< evaluation: --regime given
  std::vector<KnownFailure> known_failures;  ///< evaluation: its accepted gate failures
  /// The `--out` / `--model` value's index in `arguments` (replaced for candidates).
  std::optional<std::size_t> out_argument, model_argument;
  /// What the stage reads (the stage cache's inputs besides the tool and the argument texts).
  std::vector<StageInput> inputs;
  /// What the stage writes: `out` (a folder: its files) and any further file (a data set's CSV).
  std::vector<std::filesystem::path> outputs;
};

/// A practical margin of the regression gate, with the reason it is no news (nightly.toml's
/// [regression] and [[regression.margins]]).
struct RegressionMargin {
  std::string metric;  ///< empty: every metric
  std::optional<double> relative, absolute;
  std::string reason;
  /// As `imm-eval regression` arguments.
  [[nodiscard]] std::vector<std::string> arguments() const;
};

struct NightlyPlan {
  std::filesystem::path registry = "models";
  /// Promote candidates trained by a build of a tree with uncommitted changes (trainer_version
  /// "…-dirty"). Off: shipped models come only from committed code. For trying a plan on
  /// uncommitted code (the nightly's own tests), never in the shipped plan.
  bool allow_dirty_trainer = false;
  /// The page of the evaluations of what is shipped (write_evaluations_page).
  std::optional<std::filesystem::path> evaluations_page;
  /// The regression gate's practical margins (none: the interval alone decides).
  std::vector<RegressionMargin> margins;
  /// Every margin as `imm-eval regression` arguments, in plan order.
  [[nodiscard]] std::vector<std::string> margin_arguments() const;
  std::vector<NightlyStage> stages;
  /// The evaluations of a model stage.
  [[nodiscard]] std::vector<const NightlyStage*> evaluations_of(const std::string& model) const;
};

/// Reads and checks configs/nightly.toml (unknown keys, wrong types, an evaluation naming no
/// [[models]] stage, a model outside the registry folder are ConfigErrors).
[[nodiscard]] NightlyPlan load_nightly_plan(const std::filesystem::path& path);

/// What happened to one stage in a night.
struct StageOutcome {
  std::string kind, name;
  std::string status;  ///< ok, finding, cached, failed, promoted, held back, first, blocked
  bool failed = false, held_back = false, cached = false;
  /// evaluation: it exited kFindings (the learned model does not beat a baseline tuned on its
  /// regime; reported with its numbers in `message`, not a failure), or its gates failed only in
  /// its known failures (`known_failure` too), or a known failure of it no longer happens.
  bool finding = false;
  bool known_failure = false;
  /// It failed (or was held back) for a reason that does not follow from its inputs — a tool
  /// killed by a signal, a failed promotion, a comparison that could not be made — so the stage
  /// cache never replays it: the next night runs the stage again.
  bool transient = false;
  int exit_code = 0;
  double wall_seconds = 0.0;
  std::string message;               ///< why it failed or was held back, or what it did
  std::string command;               ///< to reproduce it
  std::filesystem::path log;         ///< stdout/stderr stem, if it ran this night
  std::filesystem::path report;      ///< evaluation: its report folder
  std::filesystem::path regression;  ///< model: the regression.json of its evaluations
  std::string night;                 ///< cached: the night it last ran (UTC date)
};

struct NightlyOptions {
  std::filesystem::path tools;  ///< folder of the imm-* executables
  std::filesystem::path reports = "reports/nightly";
  std::string night;  ///< the report folder's name (default: today's UTC date)
  bool force = false;
  /// Train every candidate that is not cached first, all in one `imm-train sweep` (its ranks take
  /// the trainings as they free up), then evaluate and promote each as usual. A training the sweep
  /// did not report on (the sweep itself failed) is trained as its own stage.
  bool sweep = false;
  /// How the sweep is started: `mpirun -np 8`, `srun` (empty: one process).
  std::vector<std::string> launcher;
  /// Called as each stage finishes (the log).
  std::function<void(const StageOutcome&)> on_finish;
};

struct NightlyResult {
  std::vector<StageOutcome> stages;
  /// How the candidates were trained, when in a sweep (for the report).
  std::string training;
  int exit_code = 0;
  double wall_seconds = 0.0;
  std::filesystem::path report_folder;
};

/// Runs the whole plan, promotes what passes, writes the morning report (index.md, index.html,
/// `latest`), and returns the outcomes and the exit code.
NightlyResult run_nightly(const NightlyPlan& plan, const NightlyOptions& options);

/// Writes `folder`/index.md and index.html for a night (plots of the evaluations embedded).
void write_morning_report(const std::filesystem::path& folder, const NightlyPlan& plan,
                          const NightlyResult& result);

/// Writes `page` (Markdown, atomically, only when it changes): every evaluation and tracker stage
/// of the plan, in plan order, with the command that reproduces it, its outcome, and its report.md
/// (the tables and gates imm-eval printed), its headings one level down. A section is rewritten
/// only when the night promoted its model (or its tracker) or the page has none: the page
/// describes what is shipped, and a night that ships nothing leaves it byte for byte. A stage
/// without a report says why.
void write_evaluations_page(const std::filesystem::path& page, const NightlyPlan& plan,
                            const NightlyResult& result);

}  // namespace imm::pipeline
