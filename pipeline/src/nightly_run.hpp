// SPDX-License-Identifier: Apache-2.0
#pragma once
// The nightly's run (nightly.hpp's run_nightly): one Night takes the registry's lock, runs the
// data and tracking stages, trains, evaluates and promotes every model stage, and collects the
// outcomes for the morning report. Its model stages are in nightly_model_stage.cpp. Not installed.

#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "imm/pipeline/nightly.hpp"
#include "imm/pipeline/registry.hpp"
#include "stage_cache.hpp"

namespace imm::pipeline {

/// The command line of a stage as the report shows it (arguments with spaces quoted).
[[nodiscard]] std::string command_line(const fs::path& tool,
                                       const std::vector<std::string>& arguments);
/// The last lines of a stage's stderr: why it failed.
[[nodiscard]] std::string tail_of(const fs::path& file, std::size_t lines = 4);
/// The gate lines of an evaluation's report ("Gates …: FAILED" and the failures under it).
[[nodiscard]] std::string gate_lines(const fs::path& file);
/// The failed lines of an evaluation's gates (the "  - " lines under "Gates", without the dash).
[[nodiscard]] std::vector<std::string> failed_gates(const fs::path& file);
/// The lines of `failed` that contain none of the known failures' `gate`.
[[nodiscard]] std::vector<std::string> unknown_failures(const std::vector<std::string>& failed,
                                                        const std::vector<KnownFailure>& known);
/// "known: " and the reasons of the known failures that some line of `failed` matches.
[[nodiscard]] std::string known_reasons(const std::vector<std::string>& failed,
                                        const std::vector<KnownFailure>& known);
/// The "Findings" block of an imm-eval report's stdout (its heading and its "  - " lines).
[[nodiscard]] std::string findings_lines(const fs::path& file);
/// Whether a failure's message says the machine ran out of room (no space left, a file-size limit,
/// a quota): not the stage's inputs' fault, so the stage cache does not keep it (StageOutcome::
/// transient) and the next night runs the stage again.
[[nodiscard]] bool out_of_room(const std::string& message);
/// Copies a stage's stdout (its tables) to ours.
void echo(const fs::path& file);
/// An outcome of a stage of that kind and name, not yet run.
[[nodiscard]] StageOutcome outcome_of(std::string kind, std::string name);

class Night {
 public:
  Night(const NightlyPlan& plan, const NightlyOptions& options);

  ~Night();
  Night(const Night&) = delete;
  Night& operator=(const Night&) = delete;

  NightlyResult run();

 private:
  fs::path tool(const NightlyStage& stage) const { return options_.tools / stage.executable; }

  fs::path log_stem(const std::string& name) const;

  // Runs a process with its output in the night's logs; echoes its stdout (the tables).
  int spawn(const fs::path& executable, const std::vector<std::string>& arguments,
            const fs::path& log, double& seconds);

  void finish(StageOutcome outcome);

  void run_plain(const NightlyStage& stage);

  // The evaluation's arguments with another model file, report folder and (optionally) regime.
  static std::vector<std::string> evaluation_arguments(const NightlyStage& e, const fs::path& model,
                                                       const fs::path& out,
                                                       const std::optional<fs::path>& regime);

  // A model stage's cache key and inputs: its own and those of the evaluations that name it.
  std::pair<std::string, std::string> model_inputs(const NightlyStage& stage);

  // Where a model stage's candidate is trained.
  fs::path staging_of(const NightlyStage& stage) const {
    return registry_.staging_folder() / stage.out.lexically_relative(plan_.registry);
  }

  // The stage's arguments with the candidate as its output.
  std::vector<std::string> candidate_arguments(const NightlyStage& stage) const;

  // Trains every model stage that is not cached in one `imm-train sweep` (NightlyOptions::sweep),
  // each into its staging file with its log where its own stage would put it. What the sweep
  // reports is taken by run_model; a training it does not report on is trained there as usual.
  void train_in_sweep();

  void run_model(const NightlyStage& stage);
  // A tracker stage: rank the shipped baseline and learned models of one regime, and promote the
  // winner as the regime's tracker (nightly_tracker_stage.cpp).
  void run_tracker(const NightlyStage& stage);

  // Temporary files of a run that was killed (".<name>.tmp-<pid>@<host>" beside models, archive
  // entries, the manifest and the cache: this host's, of dead processes), and its staged
  // candidates.
  void remove_stale_temporaries() const;

  // The plan's model stages by output file, as their own inputs digest (without evaluations).
  PlanOutputs plan_outputs();

  static std::string join(const std::vector<std::string>& parts);

  // Why the candidate is no news against the shipped model of its stage (the same model, or a
  // tie on every metric from the same definition: see nightly.hpp), or nothing when it is news.
  /// The shipped model a candidate is compared with: a copy of the manifest's model (from models/
  /// or the archive), its SHA-256 ("" when nothing is recorded under the name), or unavailable.
  struct ShippedSnapshot {
    fs::path file;  ///< the copy evaluated (empty: nothing to evaluate)
    std::string sha256;
    bool unavailable = false;  ///< recorded, but no copy with its SHA-256 exists
  };
  ShippedSnapshot snapshot_shipped(const NightlyStage& stage);
  /// Whether two model files were trained for different regimes (false when either does not read).
  static bool trained_for_another_regime(const fs::path& candidate, const fs::path& shipped);
  std::optional<std::string> no_news(const NightlyStage& stage, const fs::path& staging,
                                     const std::vector<const NightlyStage*>& evaluations);

  // The headline metrics of the candidate's evaluations, with the regression intervals when the
  // shipped model was compared.
  static nlohmann::json headline_metrics(const std::vector<const NightlyStage*>& evaluations);

  const NightlyPlan& plan_;
  const NightlyOptions& options_;
  Registry registry_;
  StageCache cache_;
  Digests digests_;
  std::string night_;
  fs::path folder_;
  std::vector<StageOutcome> outcomes_;
  struct Trained {
    int exit_code = 0;
    double seconds = 0.0;
    std::string message;
  };
  std::map<std::string, Trained> pretrained_;  ///< by model stage: what the sweep reported
  std::string training_;                       ///< how the sweep went, for the report
  int lock_ = -1;
};

}  // namespace imm::pipeline
