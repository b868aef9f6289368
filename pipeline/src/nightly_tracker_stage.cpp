// SPDX-License-Identifier: Apache-2.0
// The nightly's tracker stages: the regime's tracker chosen among its shipped models
// (`imm-eval rank`) and promoted under the stage's name (see imm/pipeline/nightly.hpp).
#include <algorithm>
#include <nlohmann/json.hpp>

#include "imm/datasets/sha256.hpp"
#include "imm/pipeline/nightly.hpp"
#include "imm/pipeline/registry.hpp"
#include "imm/support/exit_codes.hpp"
#include "imm/trainer/provenance.hpp"
#include "nightly_run.hpp"

namespace imm::pipeline {

void Night::run_tracker(const NightlyStage& stage) {
  // The stage ranks what is shipped now: a candidate never shipped is left out (its training
  // failed on a clean registry); without the baseline there is nothing to rank against.
  std::vector<std::string> arguments, left_out;
  std::size_t candidates = 0, baselines = 0;
  std::string section;
  for (const std::string& a : stage.arguments) {
    if (a.starts_with("--")) section = a;
    const bool listed = section == "--candidates" || section == "--baseline";
    if (section == "--evaluations" && !a.starts_with("--") &&
        !(fs::is_regular_file(fs::path(a) / "metrics.json") &&
          fs::is_regular_file(fs::path(a) / "report.md"))) {
      continue;  // not evaluated (its model stage failed first): no evidence for its model
    }
    if (listed && !a.starts_with("--")) {
      if (!fs::exists(a)) {
        left_out.push_back(a);
        continue;
      }
      ++(section == "--candidates" ? candidates : baselines);
    }
    arguments.push_back(a);
  }
  // No evaluation folder left: the option goes too (rank then holds every candidate out).
  if (const auto at = std::find(arguments.begin(), arguments.end(), "--evaluations");
      at != arguments.end() && (at + 1 == arguments.end() || (at + 1)->starts_with("--"))) {
    arguments.erase(at);
  }
  NightlyStage ranked = stage;
  ranked.arguments = arguments;
  ranked.out_argument = arguments.size() - 1;
  // What it no longer names, it no longer reads.
  std::erase_if(ranked.inputs, [&](const StageInput& input) {
    return std::find(arguments.begin(), arguments.end(), input.path.string()) == arguments.end();
  });
  const std::string key = "tracker:" + stage.name;
  const std::string inputs = inputs_digest(ranked, tool(ranked), digests_);
  if (!options_.force) {
    if (auto cached = cache_.find(key, inputs, digests_)) {
      cached->kind = stage.kind, cached->name = stage.name;
      return finish(*cached);
    }
  }
  StageOutcome o = outcome_of("tracker", stage.name);
  o.report = stage.report;
  if (baselines == 0 || candidates == 0) {
    o.failed = true;
    o.status = "failed";
    o.message = baselines == 0 ? "none of the regime's tuned classical filters is shipped"
                               : "no learned model of the regime is shipped";
    o.command = command_line(tool(ranked), arguments);
    return finish(o);
  }
  for (const auto& folder : stage.output_folders) fs::create_directories(folder);
  const fs::path staging = registry_.staging_folder() / ("tracker_" + stage.name + ".h5");
  fs::create_directories(staging.parent_path());
  fs::remove(staging);
  arguments.back() = staging.string();
  o.command = command_line(tool(ranked), ranked.arguments);
  o.log = log_stem("tracker_" + stage.name);
  o.exit_code = spawn(tool(ranked), arguments, o.log, o.wall_seconds);
  if ((o.exit_code != 0 && o.exit_code != support::exit_code::kFindings) || !fs::exists(staging)) {
    o.failed = true;
    o.status = "failed";
    o.message =
        "exit code " + std::to_string(o.exit_code) + ": " + tail_of(o.log.string() + ".err");
    cache_.store(key, inputs, o, {}, digests_);
    return finish(o);
  }
  try {
    const auto ranking =
        nlohmann::json::parse(trainer::read_text_file(stage.report / "tracker.json"));
    RegistryEntry entry = describe_model(staging, plan_.registry, stage.name);
    entry.file = stage.out.lexically_relative(plan_.registry).generic_string();
    entry.inputs_digest = inputs;
    entry.metrics = {{"tracker", ranking.at("tracker")},
                     {"reason", ranking.at("reason")},
                     {"rule", ranking.at("rule")},
                     {"ranking", ranking.at("ranking")}};
    // (A promotion re-reads the manifest: no pointer into the entries outlives it.)
    const RegistryEntry* shipped = registry_.find(stage.name);
    const bool had_entry = shipped != nullptr;
    const std::string winner = ranking.at("tracker").get<std::string>();
    if (had_entry && shipped->sha256 == datasets::file_sha256_hex(staging) &&
        fs::exists(stage.out)) {
      o.status = "unchanged (" + winner + ")";
    } else {
      registry_.promote(entry, staging);
      o.status = std::string(had_entry ? "promoted" : "promoted (first in the manifest)") + " (" +
                 winner + ")";
    }
    o.message = ranking.at("reason").get<std::string>();
    if (o.exit_code == support::exit_code::kFindings) {
      o.finding = true;
      o.message += "\n" + findings_lines(o.log.string() + ".out");
    }
    if (!left_out.empty()) {
      o.message += "; not ranked (never shipped): " + join(left_out);
    }
    fs::remove(staging);
  } catch (const std::exception& error) {
    o.failed = true;
    o.status = "failed";
    o.message = std::string("tracker promotion failed: ") + error.what();
    o.transient = true;
  }
  cache_.store(key, inputs, o, {stage.out}, digests_);
  finish(o);
}

}  // namespace imm::pipeline
