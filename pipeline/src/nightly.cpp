// SPDX-License-Identifier: Apache-2.0
#include "imm/pipeline/nightly.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "imm/pipeline/registry.hpp"
#include "imm/support/config.hpp"

namespace imm::pipeline {
namespace {

void add_folder_of(NightlyStage& stage, const std::string& path, bool path_is_folder = false) {
  std::filesystem::path folder =
      path_is_folder ? std::filesystem::path(path) : std::filesystem::path(path).parent_path();
  if (!folder.empty()) stage.output_folders.push_back(folder);
}

void add_input(NightlyStage& stage, StageInput::Kind kind, std::filesystem::path path) {
  stage.inputs.push_back(StageInput{kind, std::move(path)});
}

void add_optional(const support::ConfigTable& table, std::string_view key, const char* flag,
                  NightlyStage& stage) {
  if (table.has(key)) {
    stage.arguments.emplace_back(flag);
    stage.arguments.push_back(std::to_string(table.integer(key)));
  }
}

void add_optional_text(const support::ConfigTable& table, std::string_view key, const char* flag,
                       NightlyStage& stage) {
  if (table.has(key)) {
    stage.arguments.emplace_back(flag);
    stage.arguments.push_back(table.text(key));
  }
}

// A stage's `regime = …`, when given: --regime and the file as an input.
void add_regime(const support::ConfigTable& table, NightlyStage& stage) {
  if (!table.has("regime")) return;
  add_optional_text(table, "regime", "--regime", stage);
  add_input(stage, StageInput::Kind::kFile, table.text("regime"));
}

void add_passthrough(const support::ConfigTable& table, NightlyStage& stage) {
  if (table.has("arguments")) {
    for (auto& argument : table.texts("arguments")) {
      add_input(stage, StageInput::Kind::kFile, argument);  // digested when it names a file
      stage.arguments.push_back(std::move(argument));
    }
  }
}

// A stage's `out` must be a file inside the registry folder (the nightly ships nothing elsewhere).
void require_inside_registry(const support::ConfigTable& entry, const std::string& out,
                             const std::filesystem::path& registry, const std::string& what) {
  const auto relative = std::filesystem::path(out).lexically_relative(registry);
  if (relative.empty() || relative.begin()->string() == ".." || relative.is_absolute()) {
    entry.fail("out", "the " + what + " must be written inside the registry folder '" +
                          registry.string() + "'");
  }
}

NightlyStage make_stage(std::string kind, std::string name, std::string executable) {
  NightlyStage stage;
  stage.kind = std::move(kind);
  stage.name = std::move(name);
  stage.executable = std::move(executable);
  return stage;
}

RegressionMargin margin_from(const support::ConfigTable& table, bool with_metric) {
  RegressionMargin margin;
  if (with_metric) {
    margin.metric = table.text("metric");
    if (margin.metric.empty()) table.fail("metric", "must name a part of a metric's name");
  }
  for (const auto& [key, field] : {std::pair{"relative_margin", &margin.relative},
                                   std::pair{"absolute_margin", &margin.absolute}}) {
    if (!table.has(key)) continue;
    const double value = table.real(key);
    if (!std::isfinite(value) || value < 0.0) table.fail(key, "must be a finite number ≥ 0");
    *field = value;
  }
  if (!margin.relative && !margin.absolute) {
    table.fail("relative_margin", "a margin needs relative_margin or absolute_margin");
  }
  margin.reason = table.text("reason");
  if (margin.reason.find_first_not_of(" \t\n") == std::string::npos) {
    table.fail("reason", "must say why a difference within the margin is no news");
  }
  return margin;
}

NightlyPlan plan_from(const support::ConfigTable& root) {
  NightlyPlan plan;
  plan.registry = root.text_or("registry", "models");
  if (const auto regression = root.table("regression")) {
    plan.margins.push_back(margin_from(*regression, false));
    for (const auto& entry : regression->tables("margins")) {
      plan.margins.push_back(margin_from(entry, true));
    }
  }
  plan.allow_dirty_trainer = root.boolean_or("allow_dirty_trainer", false);
  if (root.has("evaluations_page")) plan.evaluations_page = root.text("evaluations_page");
  for (const auto& entry : root.tables("data")) {
    const std::string out = entry.text("out");
    NightlyStage stage = make_stage("data", entry.text("name"), "imm-data");
    const std::string command = entry.text("command");
    if (command == "export" || command == "import") {  // a recorded regime's recordings
      stage.arguments = {command, command == "export" ? "--out-dir" : "--out", out};
      stage.out = out;
      stage.outputs = {out};
      add_folder_of(stage, out, command == "export");
      if (command == "export") {
        stage.arguments.insert(stage.arguments.end(), {"--regime", entry.text("regime")});
        add_input(stage, StageInput::Kind::kFile, entry.text("regime"));
        add_optional_text(entry, "split", "--split", stage);
        add_optional(entry, "count", "--count", stage);
        add_optional(entry, "seed", "--seed", stage);
        if (entry.boolean_or("no_truth", false)) stage.arguments.emplace_back("--no-truth");
      } else {
        add_optional_text(entry, "units", "--units", stage);
        add_optional_text(entry, "sensor", "--sensor", stage);
        add_optional_text(entry, "set_name", "--name", stage);
        for (auto& input : entry.texts("inputs")) {
          add_input(stage, StageInput::Kind::kRecordings, input);
          stage.arguments.push_back(std::move(input));
        }
      }
      plan.stages.push_back(std::move(stage));
      continue;
    }
    stage.arguments = {command, "--regime", entry.text("regime"), "--out", out};
    stage.out = out;
    stage.outputs = {out};
    add_input(stage, StageInput::Kind::kFile, entry.text("regime"));
    add_folder_of(stage, out);
    add_optional_text(entry, "split", "--split", stage);
    if (entry.has("csv")) {
      const std::string csv = entry.text("csv");
      stage.arguments.insert(stage.arguments.end(), {"--csv", csv});
      stage.outputs.emplace_back(csv);
      add_folder_of(stage, csv);
    }
    add_optional(entry, "count", "--count", stage);
    add_optional(entry, "seed", "--seed", stage);
    plan.stages.push_back(std::move(stage));
  }
  const auto models = root.tables("models");
  for (std::size_t i = 0; i < models.size(); ++i) {
    const auto& entry = models[i];
    NightlyStage stage = make_stage("model", entry.text("name"), "imm-train");
    // The name becomes a registry entry's: one path component (registry.hpp).
    if (const std::string problem = model_name_problem(stage.name); !problem.empty()) {
      entry.fail("name", problem);
    }
    const std::string out = entry.text("out");
    stage.arguments = {entry.text("command"), "--config", entry.text("config"), "--out", out};
    stage.out = out;
    stage.outputs = {out};
    stage.out_argument = 4;
    add_input(stage, StageInput::Kind::kTrainerConfig, entry.text("config"));
    require_inside_registry(entry, out, plan.registry, "model");
    for (const auto& other : plan.stages) {
      if (other.kind == "model" && other.name == stage.name) {
        entry.fail("name", "a second model stage named '" + stage.name + "'");
      }
    }
    add_folder_of(stage, out);
    add_regime(entry, stage);
    add_optional(entry, "seed", "--seed", stage);
    add_passthrough(entry, stage);
    plan.stages.push_back(std::move(stage));
  }
  for (const auto& entry : root.tables("tracks")) {
    const std::string out = entry.text("out");
    NightlyStage stage = make_stage("track", out, "imm-track");
    stage.arguments = {"--filter",       entry.text("filter"),
                       "--measurements", entry.text("measurements"),
                       "--out",          out};
    stage.out = out;
    stage.outputs = {out};
    add_input(stage, StageInput::Kind::kFile, entry.text("filter"));
    add_input(stage, StageInput::Kind::kFile, entry.text("measurements"));
    add_folder_of(stage, out);
    plan.stages.push_back(std::move(stage));
  }
  for (const auto& entry : root.tables("evaluations")) {
    NightlyStage stage = make_stage("evaluation", entry.text("experiment"), "imm-eval");
    const std::string out = entry.text("out");
    stage.model = entry.text("model");
    const auto linked = std::find_if(plan.stages.begin(), plan.stages.end(), [&](const auto& s) {
      return s.kind == "model" && s.name == stage.model;
    });
    if (linked == plan.stages.end()) {
      entry.fail("model", "names no [[models]] stage ('" + stage.model + "')");
    }
    stage.name = stage.name + " " + stage.model;
    stage.out = out;
    stage.arguments = {entry.text("experiment"),
                       "--models",
                       entry.text_or("models", plan.registry.string()),
                       "--out",
                       out,
                       "--model",
                       linked->out.string()};
    stage.out_argument = 4;
    stage.model_argument = 6;
    stage.outputs = {out};
    add_input(stage, StageInput::Kind::kModelFolder, stage.arguments[2]);
    add_folder_of(stage, out, true);
    stage.has_regime = entry.has("regime");
    add_regime(entry, stage);
    add_optional(entry, "runs", "--runs", stage);
    add_optional(entry, "seed", "--seed", stage);
    add_passthrough(entry, stage);
    for (const auto& known : entry.tables("known_failures")) {
      KnownFailure failure{known.text("gate"), known.text("reason")};
      if (failure.gate.find_first_not_of(" \t\n") == std::string::npos) {
        known.fail("gate", "must name a part of the failed gate's line");
      }
      if (failure.reason.find_first_not_of(" \t\n") == std::string::npos) {
        known.fail("reason", "must say why the failure is known and accepted");
      }
      stage.known_failures.push_back(std::move(failure));
    }
    plan.stages.push_back(std::move(stage));
  }
  for (const auto& entry : root.tables("trackers")) {
    NightlyStage stage = make_stage("tracker", entry.text("name"), "imm-eval");
    if (const std::string problem = model_name_problem(stage.name); !problem.empty()) {
      entry.fail("name", problem);
    }
    const auto model_out = [&](const std::string& key, const std::string& name) {
      const auto linked = std::find_if(plan.stages.begin(), plan.stages.end(), [&](const auto& s) {
        return s.kind == "model" && s.name == name;
      });
      if (linked == plan.stages.end()) {
        entry.fail(key, "names no [[models]] stage ('" + name + "')");
      }
      return linked->out.string();
    };
    const std::string out = entry.text("out");
    require_inside_registry(entry, out, plan.registry, "tracker");
    const auto candidates = entry.texts("candidates");
    if (candidates.empty()) entry.fail("candidates", "lists no learned model");
    // The regime's tuned classical filters: `baseline` (one) and/or `baselines` (several); the
    // best of them on the test tracks is the bar every candidate faces.
    std::vector<std::string> baselines;
    if (entry.has("baseline")) baselines.push_back(entry.text("baseline"));
    if (entry.has("baselines")) {
      for (const auto& b : entry.texts("baselines")) baselines.push_back(b);
    }
    if (baselines.empty()) entry.fail("baselines", "names no tuned classical filter");
    stage.arguments = {"rank", "--baseline"};
    for (const auto& b : baselines) {
      stage.arguments.push_back(model_out(entry.has("baselines") ? "baselines" : "baseline", b));
      add_input(stage, StageInput::Kind::kFile, stage.arguments.back());
    }
    stage.arguments.push_back("--candidates");
    for (const auto& candidate : candidates) {
      stage.arguments.push_back(model_out("candidates", candidate));
      add_input(stage, StageInput::Kind::kFile, stage.arguments.back());
    }
    // The candidates' own evaluations: rank holds out a model whose gates failed there, or that
    // none of them evaluated (the night evaluates candidates, so a shipped model that was not
    // tonight's or an earlier night's candidate has none).
    std::vector<std::string> evaluated;
    for (const auto& candidate : candidates) {
      for (const NightlyStage* e : plan.evaluations_of(candidate)) {
        evaluated.push_back(e->out.string());
        // The shipped model's evaluation when the night's candidate did not replace it.
        evaluated.push_back((e->out / "shipped").string());
        add_input(stage, StageInput::Kind::kVerdicts, e->out);
        add_input(stage, StageInput::Kind::kVerdicts, e->out / "shipped");
      }
    }
    if (!evaluated.empty()) {
      stage.arguments.push_back("--evaluations");
      stage.arguments.insert(stage.arguments.end(), evaluated.begin(), evaluated.end());
    }
    const std::string report = entry.text("report");
    stage.arguments.insert(stage.arguments.end(), {"--out", report});
    add_optional(entry, "runs", "--runs", stage);
    add_optional(entry, "seed", "--seed", stage);
    stage.arguments.insert(stage.arguments.end(), {"--ship", out});
    stage.out_argument = stage.arguments.size() - 1;
    stage.out = out;
    stage.outputs = {out};
    stage.report = report;
    add_folder_of(stage, out);
    add_folder_of(stage, report, true);
    plan.stages.push_back(std::move(stage));
  }
  if (plan.stages.empty()) root.fail("models", "the plan lists no stages");
  return plan;
}

}  // namespace

std::vector<std::string> RegressionMargin::arguments() const {
  const std::string prefix = metric.empty() ? "" : metric + "=";
  std::vector<std::string> texts;
  auto number = [](double value) {
    std::ostringstream text;
    text.precision(17);
    text << value;
    return text.str();
  };
  if (relative) texts.insert(texts.end(), {"--relative-margin", prefix + number(*relative)});
  if (absolute) texts.insert(texts.end(), {"--absolute-margin", prefix + number(*absolute)});
  return texts;
}

std::vector<std::string> NightlyPlan::margin_arguments() const {
  std::vector<std::string> all;
  for (const RegressionMargin& margin : margins) {
    for (std::string& a : margin.arguments()) all.push_back(std::move(a));
  }
  return all;
}

std::vector<const NightlyStage*> NightlyPlan::evaluations_of(const std::string& model) const {
  std::vector<const NightlyStage*> found;
  for (const auto& stage : stages) {
    if (stage.kind == "evaluation" && stage.model == model) found.push_back(&stage);
  }
  return found;
}

NightlyPlan load_nightly_plan(const std::filesystem::path& path) {
  const auto document = support::ConfigDocument::load(path);
  return document->load_checked([&] { return plan_from(document->root()); });
}

}  // namespace imm::pipeline
