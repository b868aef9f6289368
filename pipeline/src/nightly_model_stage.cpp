// SPDX-License-Identifier: Apache-2.0
// The nightly's model stages: a candidate trained into staging (alone or in one sweep),
// evaluated beside the shipped model on the same runs, and promoted only past its gates.
#include "nightly_run.hpp"

// The nightly run: stages, the candidate → evaluation → regression → promotion path of each
// model, the stage cache, and the exit code (see imm/pipeline/nightly.hpp).

#include <fcntl.h>
#include <sys/file.h>
#include <toml++/toml.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "imm/datasets/sha256.hpp"
#include "imm/io/model_file.hpp"
#include "imm/pipeline/nightly.hpp"
#include "imm/pipeline/registry.hpp"
#include "imm/support/exit_codes.hpp"
#include "imm/support/process.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::pipeline {

std::vector<std::string> Night::evaluation_arguments(const NightlyStage& e, const fs::path& model,
                                                     const fs::path& out,
                                                     const std::optional<fs::path>& regime) {
  std::vector<std::string> arguments = e.arguments;
  arguments[*e.model_argument] = model.string();
  arguments[*e.out_argument] = out.string();
  if (regime && !e.has_regime) arguments.insert(arguments.end(), {"--regime", regime->string()});
  return arguments;
}

std::pair<std::string, std::string> Night::model_inputs(const NightlyStage& stage) {
  std::vector<std::string> evaluation_texts;
  for (const NightlyStage* e : plan_.evaluations_of(stage.name)) {
    evaluation_texts.push_back(inputs_digest(*e, tool(*e), digests_, {}, plan_outputs()));
  }
  // The regression gate's margins and the known failures decide with the evaluations.
  for (const NightlyStage* e : plan_.evaluations_of(stage.name)) {
    for (const KnownFailure& k : e->known_failures) {
      evaluation_texts.push_back("known failure of " + e->name + ": " + k.gate + "\n" + k.reason);
    }
  }
  for (std::string& a : plan_.margin_arguments()) evaluation_texts.push_back(std::move(a));
  return {"model:" + stage.name, inputs_digest(stage, tool(stage), digests_, evaluation_texts)};
}

std::vector<std::string> Night::candidate_arguments(const NightlyStage& stage) const {
  std::vector<std::string> arguments = stage.arguments;
  arguments[*stage.out_argument] = staging_of(stage).string();
  return arguments;
}

void Night::train_in_sweep() {
  std::vector<const NightlyStage*> stages;
  for (const NightlyStage& stage : plan_.stages) {
    if (stage.kind != "model") continue;
    try {
      const auto [key, inputs] = model_inputs(stage);
      if (options_.force || !cache_.find(key, inputs, digests_)) stages.push_back(&stage);
    } catch (const std::exception&) {
      continue;  // its inputs do not read: its own stage fails, saying why
    }
  }
  // Longest first, by what each took the last time (one never run counts as the longest):
  // the sweep hands jobs out in plan order, so a long training started last would leave the
  // other ranks idle while it finishes.
  const auto cost = [this](const NightlyStage* stage) {
    return cache_.last_seconds("model:" + stage->name)
        .value_or(std::numeric_limits<double>::infinity());
  };
  std::stable_sort(stages.begin(), stages.end(),
                   [&](const NightlyStage* a, const NightlyStage* b) { return cost(a) > cost(b); });
  toml::array jobs;
  for (const NightlyStage* s : stages) {
    const NightlyStage& stage = *s;
    for (const auto& folder : stage.output_folders) fs::create_directories(folder);
    const fs::path staging = staging_of(stage);
    fs::create_directories(staging.parent_path());
    fs::remove(staging);
    toml::array command;
    for (const auto& a : candidate_arguments(stage)) command.push_back(a);
    jobs.push_back(toml::table{{"name", stage.name},
                               {"command", std::move(command)},
                               {"log", log_stem("model_" + stage.name).string()}});
  }
  if (stages.empty()) return;
  fs::create_directories(registry_.staging_folder());
  const fs::path sweep_plan = registry_.staging_folder() / "sweep.toml";
  const fs::path summary = registry_.staging_folder() / "sweep.json";
  std::ofstream(sweep_plan) << toml::table{{"jobs", std::move(jobs)}} << '\n';
  std::vector<std::string> arguments(options_.launcher.begin(), options_.launcher.end());
  arguments.push_back((options_.tools / "imm-train").string());
  arguments.insert(arguments.end(),
                   {"sweep", "--config", sweep_plan.string(), "--summary", summary.string()});
  const fs::path executable = arguments.front();
  arguments.erase(arguments.begin());
  const fs::path log = log_stem("sweep");
  fs::remove(summary);
  double seconds = 0.0;
  const int code = spawn(executable, arguments, log, seconds);
  std::size_t reported = 0;
  int ranks = 0;
  try {
    const auto document = nlohmann::json::parse(trainer::read_text_file(summary));
    ranks = document.at("ranks").get<int>();
    for (const auto& job : document.at("jobs")) {
      pretrained_[job.at("name").get<std::string>()] = {job.at("exit_code").get<int>(),
                                                        job.at("seconds").get<double>(),
                                                        job.at("message").get<std::string>()};
      ++reported;
    }
  } catch (const std::exception& error) {
    std::cerr << "imm-train: the sweep reported no outcomes (" << error.what() << ")\n";
  }
  std::ostringstream text;
  text.precision(1);
  text << std::fixed;
  const std::string candidates =
      std::to_string(stages.size()) + " candidate" + (stages.size() == 1 ? "" : "s");
  const std::string how = "`" + command_line(executable, arguments) + "`";
  if (code == 0 || (code == support::exit_code::kJobFailed && reported == stages.size())) {
    text << candidates << " trained in one sweep over " << ranks << " rank"
         << (ranks == 1 ? "" : "s") << " in " << seconds << " s (" << how << ")";
  } else {
    const std::string why = tail_of(log.string() + ".err", 2);
    text << "the sweep of " << candidates << " (" << how << ") ended with exit code " << code
         << " after " << seconds << " s" << (why.empty() ? "" : ": " + why);
  }
  if (reported < stages.size()) {
    text << "; the candidates it did not report on (" << stages.size() - reported
         << ") were trained as their own stages";
  }
  training_ = text.str();
  std::cerr << "imm-train: " << training_ << '\n';
}

void Night::run_model(const NightlyStage& stage) {
  const auto evaluations = plan_.evaluations_of(stage.name);
  const auto identity = model_inputs(stage);
  const std::string& key = identity.first;
  const std::string& inputs = identity.second;
  if (registry_.find(stage.name) == nullptr && fs::is_regular_file(stage.out)) {
    // A model shipped before the manifest existed: recorded as it is, then compared as usual.
    try {
      RegistryEntry entry = describe_model(stage.out, plan_.registry, stage.name);
      entry.file = stage.out.lexically_relative(plan_.registry).generic_string();
      registry_.adopt(entry);
    } catch (const std::exception& error) {
      std::cerr << "imm-train: " << stage.out.string()
                << " is not recorded in the manifest: " << error.what() << '\n';
    }
  }
  const bool had_entry = registry_.find(stage.name) != nullptr;
  if (!options_.force) {
    if (auto cached = cache_.find(key, inputs, digests_)) {
      cached->kind = "model", cached->name = stage.name;
      finish(*cached);
      for (const NightlyStage* e : evaluations) {
        if (auto c =
                cache_.find("evaluation:" + e->name + ":" + e->out.string(), inputs, digests_)) {
          c->kind = "evaluation", c->name = e->name;
          finish(*c);
        }
      }
      return;
    }
  }
  const fs::path staging = staging_of(stage);
  StageOutcome model = outcome_of("model", stage.name);
  const std::vector<std::string> arguments = candidate_arguments(stage);
  model.command = command_line(tool(stage), arguments);
  model.log = log_stem("model_" + stage.name);
  std::string swept_message;
  if (const auto swept = pretrained_.find(stage.name); swept != pretrained_.end()) {
    model.exit_code = swept->second.exit_code;
    model.wall_seconds = swept->second.seconds;
    swept_message = swept->second.message;
    echo(model.log.string() + ".out");
  } else {
    for (const auto& folder : stage.output_folders) fs::create_directories(folder);
    fs::create_directories(staging.parent_path());
    fs::remove(staging);
    model.exit_code = spawn(tool(stage), arguments, model.log, model.wall_seconds);
  }
  std::vector<StageOutcome> evaluation_outcomes;
  // Each evaluation's report folder and where tonight's evaluation of the shipped model went.
  std::vector<std::pair<fs::path, fs::path>> shipped_reports;
  auto conclude = [&](const StageOutcome& m) {
    // `<report>/shipped/`: the evaluation of the model that stays shipped (its metrics.json and
    // report.md), kept beside the
    // candidate's, so that its gates are on record for the tracker stage (imm-eval rank holds out
    // a model no evaluation of which passed its gates). Gone when the candidate is shipped.
    const bool promoted = m.status.starts_with("promoted");
    for (const auto& [report, shipped_out] : shipped_reports) {
      std::error_code error;
      fs::remove_all(report / "shipped", error);
      if (!promoted && fs::is_regular_file(shipped_out / "report.md", error) &&
          fs::is_regular_file(shipped_out / "metrics.json", error)) {
        try {
          fs::create_directories(report / "shipped");
          for (const char* name : {"metrics.json", "report.md"}) {
            trainer::copy_atomically(shipped_out / name, report / "shipped" / name);
          }
        } catch (const std::exception&) {
          fs::remove_all(report / "shipped", error);  // no record: rank holds the model out
        }
      }
    }
    cache_.store(key, inputs, m, {stage.out}, digests_);
    finish(m);
    for (auto& e : evaluation_outcomes) {
      cache_.store("evaluation:" + e.name + ":" + e.report.string(), inputs, e, {}, digests_);
      finish(e);
    }
  };
  if (model.exit_code != 0 || !fs::exists(staging)) {
    model.failed = true;
    model.status = "failed";
    std::string why = tail_of(model.log.string() + ".err");
    // An error the sweep caught after the job's log was closed.
    if (!swept_message.empty() && why.find(swept_message) == std::string::npos &&
        !swept_message.starts_with("exit code")) {
      why += (why.empty() ? "" : "\n") + swept_message;
    }
    model.message = "training failed (exit code " + std::to_string(model.exit_code) + "): " + why;
    model.transient = out_of_room(why);
    return conclude(model);
  }
  // The candidate's own evaluations (its quality gates), then the shipped model's on the same
  // tracks and the regression comparison. The shipped model is what the manifest says now, copied
  // aside so that a promotion or a rollback by hand meanwhile cannot change what is compared; the
  // promotion is then refused unless that model is still the one shipped (PromotionTerms).
  registry_.reload();
  const ShippedSnapshot shipped = snapshot_shipped(stage);
  const bool comparable_shipped = !shipped.file.empty();
  const fs::path& shipped_file = shipped.file;
  std::vector<std::string> regressions, uncompared, gate_failures, comparisons, findings;
  if (shipped.unavailable) {
    uncompared.push_back("the shipped model " + shipped.sha256.substr(0, 12) +
                         " is neither in models/ nor in the archive as the manifest says");
  }
  for (const NightlyStage* e : evaluations) {
    StageOutcome o = outcome_of("evaluation", e->name);
    o.report = e->out;
    fs::create_directories(e->out);
    fs::remove(e->out / "regression.json");
    fs::remove(e->out / "report.md");  // imm-eval writes it (headings, models, definitions)
    const auto candidate_arguments = evaluation_arguments(*e, staging, e->out, std::nullopt);
    o.command = command_line(tool(*e), candidate_arguments);
    o.log = log_stem("evaluation_" + e->name + "_" + e->out.filename().string() +
                     e->out.parent_path().filename().string());
    o.exit_code = spawn(tool(*e), candidate_arguments, o.log, o.wall_seconds);
    const fs::path out_log = o.log.string() + ".out";
    const std::vector<std::string> failed = o.exit_code == support::exit_code::kEvaluationGateFailed
                                                ? failed_gates(out_log)
                                                : std::vector<std::string>{};
    if (!failed.empty() && unknown_failures(failed, e->known_failures).empty()) {
      // Every failed gate is a known, accepted one (nightly.hpp's KnownFailure): reported with
      // its reason; the candidate goes on to the regression gate like any other.
      o.finding = o.known_failure = true;
      o.status = "known failure";
      o.message = "its gates failed only where they are known to: " + join(failed) + " (" +
                  known_reasons(failed, e->known_failures) + ")";
      findings.push_back(e->name + " (known failure)");
    } else if (o.exit_code == support::exit_code::kEvaluationGateFailed) {
      o.failed = true;
      o.status = "gate failed";
      o.message = "quality gate failed: " + gate_lines(out_log);
      gate_failures.push_back(e->name);
    } else if (o.exit_code == support::exit_code::kFindings) {
      // Every gate passed; the report has findings (the learned model does not beat a baseline
      // tuned on its regime). The candidate goes on to the regression gate like any other.
      o.finding = true;
      o.status = "finding";
      o.message = findings_lines(out_log);
      findings.push_back(e->name);
    } else if (o.exit_code != 0) {
      o.failed = true;
      o.status = "failed";
      o.message =
          "exit code " + std::to_string(o.exit_code) + ": " + tail_of(o.log.string() + ".err");
      // Killed, or out of room: not the candidate's verdict.
      o.transient = o.exit_code > 128 || o.exit_code < 0 || out_of_room(o.message);
      model.transient = model.transient || o.transient;
      gate_failures.push_back(e->name);
    } else {
      o.status = "ok";
    }
    if ((o.exit_code == 0 || o.exit_code == support::exit_code::kFindings) &&
        !e->known_failures.empty()) {
      // News: a gate the plan expects to fail passed.
      o.finding = true;
      o.status = "finding";
      std::vector<std::string> gates;
      for (const KnownFailure& k : e->known_failures) gates.push_back("'" + k.gate + "'");
      o.message += std::string(o.message.empty() ? "" : "\n") + "its known failure " + join(gates) +
                   " no longer happens: every gate passed; remove it from the plan's "
                   "[[evaluations.known_failures]]";
      if (findings.empty() || findings.back() != e->name) findings.push_back(e->name);
    }
    if (!o.failed && comparable_shipped) {
      const fs::path shipped_out = registry_.staging_folder() / "shipped" /
                                   (stage.name + "_" + std::to_string(evaluation_outcomes.size()));
      fs::create_directories(shipped_out);
      const auto shipped_arguments = evaluation_arguments(*e, shipped_file, shipped_out, staging);
      shipped_reports.emplace_back(e->out, shipped_out);
      const fs::path shipped_log = o.log.string() + "_shipped";
      const int shipped_code = spawn(tool(*e), shipped_arguments, shipped_log, o.wall_seconds);
      if (shipped_code == 0 || shipped_code == support::exit_code::kEvaluationGateFailed ||
          shipped_code == support::exit_code::kFindings) {
        std::vector<std::string> compare = {"regression",   "--candidate",        e->out.string(),
                                            "--shipped",    shipped_out.string(), "--out",
                                            e->out.string()};
        for (std::string& a : plan_.margin_arguments()) compare.push_back(std::move(a));
        const fs::path compare_log = o.log.string() + "_regression";
        const int verdict =
            spawn(options_.tools / "imm-eval", compare, compare_log, o.wall_seconds);
        model.regression = e->out / "regression.json";
        if (verdict == support::exit_code::kRegression) {
          regressions.push_back(e->name + ":\n" + tail_of(compare_log.string() + ".out", 40));
        } else if (verdict != 0) {
          // A comparison that could not be made is no evidence that the candidate is not worse:
          // the gate fails closed (a malformed headline, runs that differ, a killed or missing
          // tool all hold the candidate back, saying why).
          uncompared.push_back(e->name + ": the comparison with the shipped model failed (exit " +
                               std::to_string(verdict) + ": " +
                               tail_of(compare_log.string() + ".err", 2) + ")");
        }
      } else if (shipped_code == support::exit_code::kBadInput &&
                 !out_of_room(tail_of(shipped_log.string() + ".err")) &&
                 trained_for_another_regime(staging, shipped_file)) {
        // The one comparison that cannot be made by its nature: the shipped model refuses the
        // candidate's regime (a new regime for the name). Anything else is no evidence.
        comparisons.push_back(e->name +
                              ": the shipped model, trained for another regime, could not be "
                              "evaluated on the candidate's (" +
                              tail_of(shipped_log.string() + ".err", 2) +
                              "): promoted on its own gates");
      } else {
        // Killed, out of room, a tool that failed: the gate fails closed.
        uncompared.push_back(e->name + ": the evaluation of the shipped model failed (exit " +
                             std::to_string(shipped_code) + ": " +
                             tail_of(shipped_log.string() + ".err", 2) + ")");
      }
    }
    evaluation_outcomes.push_back(o);
  }
  if (!gate_failures.empty()) {
    model.failed = true;
    model.status = "not promoted";
    model.message = "the candidate failed its evaluation (" + join(gate_failures) +
                    "); the shipped model stays";
    return conclude(model);
  }
  if (!regressions.empty()) {
    model.held_back = true;
    model.status = "held back";
    model.message = "worse than the shipped model beyond the uncertainty — " + join(regressions);
    return conclude(model);
  }
  if (!uncompared.empty()) {
    model.held_back = true;
    model.transient = true;  // the next night compares again
    model.status = "held back";
    model.message = "not compared with the shipped model, so not promoted — " + join(uncompared);
    return conclude(model);
  }
  if (!options_.force) {
    if (const auto rejected = registry_.rejection(stage.name, staging, inputs)) {
      // A person rolled this model back: it is not shipped again until a person says so.
      model.status = "not promoted (rolled back)";
      model.message = "the candidate is the model " + rejected->sha256.substr(0, 12) +
                      " that was rolled back on " + rejected->rolled_back_utc +
                      "; `imm-train all --force` (or `imm-train promote`) ships it again";
      fs::remove(staging);
      fs::remove(trainer::metrics_path(staging));
      return conclude(model);
    }
  }
  if (const auto why = no_news(stage, staging, evaluations)) {
    model.status = "kept (ties the shipped model)";
    model.message = *why;
    if (!findings.empty()) model.message += "; with findings (" + join(findings) + ")";
    fs::remove(staging);
    fs::remove(trainer::metrics_path(staging));
    return conclude(model);
  }
  try {
    RegistryEntry entry = describe_model(staging, plan_.registry, stage.name);
    if (from_uncommitted_code(entry) && !plan_.allow_dirty_trainer) {
      model.failed = true;
      model.status = "not promoted";
      model.message = "trained by a build of uncommitted code (trainer_version " +
                      entry.trainer_version +
                      "): shipped models come only from committed code; commit and rerun";
      return conclude(model);
    }
    entry.file = stage.out.lexically_relative(plan_.registry).generic_string();
    entry.inputs_digest = inputs;
    entry.metrics = headline_metrics(evaluations);
    registry_.promote(entry, staging, trainer::metrics_path(staging),
                      PromotionTerms{shipped.sha256, !options_.force});
    model.status = had_entry ? "promoted" : "promoted (first in the manifest)";
    if (!findings.empty()) comparisons.push_back("with findings (" + join(findings) + ")");
    model.message = comparisons.empty() ? "" : join(comparisons);
    fs::remove(staging);
    fs::remove(trainer::metrics_path(staging));
  } catch (const PromotionRefused& refused) {
    // The manifest changed under the night: decided on what is shipped now.
    if (refused.why() == PromotionRefused::Why::kRolledBack) {
      model.status = "not promoted (rolled back)";
      model.message = std::string(refused.what()) +
                      " while the night ran; `imm-train all --force` (or `imm-train promote`) "
                      "ships it again";
    } else {
      model.held_back = true;
      model.transient = true;  // the next night compares with what is shipped then
      model.status = "held back";
      model.message = refused.what();
    }
    fs::remove(staging);
    fs::remove(trainer::metrics_path(staging));
  } catch (const std::exception& error) {
    model.failed = true;
    model.status = "failed";
    model.message = std::string("promotion failed: ") + error.what();
    model.transient = true;
  }
  conclude(model);
}

}  // namespace imm::pipeline
