// SPDX-License-Identifier: Apache-2.0
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
namespace {

namespace fs = std::filesystem;

std::string command_line(const fs::path& tool, const std::vector<std::string>& arguments) {
  std::string text = tool.filename().string();
  for (const auto& a : arguments) {
    text += ' ';
    text += a.find_first_of(" \"'") == std::string::npos ? a : "'" + a + "'";
  }
  return text;
}

// The last lines of a stage's stderr: why it failed.
std::string tail_of(const fs::path& file, std::size_t lines = 4) {
  std::ifstream in(file);
  std::vector<std::string> all;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty()) all.push_back(line);
  }
  std::string text;
  for (std::size_t i = all.size() > lines ? all.size() - lines : 0; i < all.size(); ++i) {
    if (!text.empty()) text += '\n';
    text += all[i];
  }
  return text;
}

// The gate lines of an evaluation's report ("Gates …: FAILED" and the failures under it).
std::string gate_lines(const fs::path& file) {
  std::ifstream in(file);
  std::string text;
  bool in_gates = false;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("Gates", 0) == 0) in_gates = true;
    if (in_gates && (line.rfind("Gates", 0) == 0 || line.rfind("  - ", 0) == 0)) {
      text += (text.empty() ? "" : "\n") + line;
    } else if (in_gates && line.empty()) {
      in_gates = false;
    }
  }
  return text.empty() ? tail_of(file, 3) : text;
}

void echo(const fs::path& file) {
  std::ifstream in(file);
  // An empty file would set failbit on std::cout and silence everything after it.
  if (in.peek() == std::ifstream::traits_type::eof()) return;
  std::cout << in.rdbuf();
  std::cout.flush();
}

// The regime file a trainer config names (regime = "…"), for the inputs digest.
std::optional<std::string> config_regime(const fs::path& config) {
  std::ifstream in(config);
  static const std::regex line(R"re(^\s*regime\s*=\s*"([^"]+)")re");
  for (std::string text; std::getline(in, text);) {
    std::smatch match;
    if (std::regex_search(text, match, line)) return match[1].str();
  }
  return std::nullopt;
}

class Digests {
 public:
  std::string of_file(const fs::path& path) {
    const std::string key = fs::absolute(path).lexically_normal().string();
    auto it = cache_.find(key);
    if (it != cache_.end()) return it->second;
    return cache_[key] = datasets::file_sha256_hex(path);
  }
  void forget(const fs::path& path) {
    cache_.erase(fs::absolute(path).lexically_normal().string());
  }

 private:
  std::map<std::string, std::string> cache_;
};

// Everything a stage reads: its tool, its arguments, and the bytes of every file they name (a
// folder: its model files; a trainer config: the regime it names).
// A model file that a stage of the plan produces stands for that stage's inputs in another
// stage's digest (its bytes change with every retraining: the training date is in them), and
// counts whether or not it exists yet, so that the first night a new model appears does not
// change the digests of the stages before it.
using PlanOutputs = std::map<std::string, std::string>;  // normalized file → stage digest

std::string normal_path(const fs::path& path) {
  return fs::absolute(path).lexically_normal().string();
}

std::string inputs_digest(const NightlyStage& stage, const fs::path& tool, Digests& digests,
                          const std::vector<std::string>& extra = {},
                          const PlanOutputs& plan_outputs = {}) {
  datasets::Sha256 hash;
  hash.update(stage.kind + '\n' + digests.of_file(tool) + '\n');
  auto add_file = [&](const fs::path& path) {
    hash.update(path.string() + '=' + digests.of_file(path) + '\n');
  };
  for (std::size_t i = 0; i < stage.arguments.size(); ++i) {
    const std::string& a = stage.arguments[i];
    hash.update(a + '\n');
    // What it writes, and an evaluation's model (the model stage's output, digested there).
    if (stage.out_argument && i == *stage.out_argument) continue;
    if (i > 0 && (stage.arguments[i - 1] == "--out" ||
                  (stage.kind == "data" && stage.arguments[i - 1] == "--csv"))) {
      continue;  // what the stage writes
    }
    if (stage.model_argument && i == *stage.model_argument) continue;
    std::error_code error;
    if (fs::is_regular_file(a, error)) {
      add_file(a);
      if (i > 0 && stage.arguments[i - 1] == "--config") {
        if (auto regime = config_regime(a); regime && fs::is_regular_file(*regime))
          add_file(*regime);
      }
    } else if (fs::is_directory(a, error) && stage.kind == "evaluation") {
      const std::string folder = normal_path(a);
      const std::string evaluated =
          stage.model_argument ? normal_path(stage.arguments[*stage.model_argument]) : "";
      std::map<std::string, std::string> files;  // path relative to the folder → digest
      for (const auto& [file, digest] : plan_outputs) {
        const fs::path relative = fs::path(file).lexically_relative(folder);
        if (!relative.empty() && *relative.begin() != ".." && file != evaluated) {
          files[relative.generic_string()] = "stage " + digest;
        }
      }
      for (const auto& f : fs::recursive_directory_iterator(a)) {
        const auto relative = f.path().lexically_relative(a).generic_string();
        if (f.is_regular_file() && f.path().extension() == ".h5" && relative[0] != '.' &&
            normal_path(f.path()) != evaluated && !files.contains(relative)) {
          files[relative] = digests.of_file(f.path());
        }
      }
      for (const auto& [relative, digest] : files) hash.update(relative + '=' + digest + '\n');
    }
  }
  for (const auto& e : extra) hash.update(e + '\n');
  return hash.hex_digest();
}

struct CacheRecord {
  std::string inputs;
  StageOutcome outcome;
  std::map<std::string, std::string> outputs;  // file → sha256
};

class StageCache {
 public:
  explicit StageCache(fs::path path) : path_(std::move(path)) {
    if (!fs::exists(path_)) return;
    try {
      const auto document = nlohmann::json::parse(trainer::read_text_file(path_));
      for (const auto& [key, r] : document.at("stages").items()) {
        CacheRecord record;
        record.inputs = r.at("inputs").get<std::string>();
        record.outcome.status = r.at("status").get<std::string>();
        record.outcome.failed = r.at("failed").get<bool>();
        record.outcome.held_back = r.at("held_back").get<bool>();
        record.outcome.exit_code = r.at("exit_code").get<int>();
        record.outcome.message = r.at("message").get<std::string>();
        record.outcome.command = r.at("command").get<std::string>();
        record.outcome.report = r.value("report", "");
        record.outcome.regression = r.value("regression", "");
        record.outcome.night = r.at("night").get<std::string>();
        record.outcome.wall_seconds = r.value("wall_seconds", 0.0);
        record.outputs = r.at("outputs").get<std::map<std::string, std::string>>();
        records_[key] = std::move(record);
      }
    } catch (const std::exception& error) {
      std::cerr << "imm-train: ignoring an unreadable stage cache " << path_.string() << " ("
                << error.what() << ")\n";
      records_.clear();
    }
  }

  // The cached outcome when the inputs match and every output is still what the stage wrote.
  std::optional<StageOutcome> find(const std::string& key, const std::string& inputs,
                                   Digests& digests) const {
    const auto it = records_.find(key);
    if (it == records_.end() || it->second.inputs != inputs) return std::nullopt;
    for (const auto& [file, sha] : it->second.outputs) {
      if (!fs::is_regular_file(file) || digests.of_file(file) != sha) return std::nullopt;
    }
    StageOutcome outcome = it->second.outcome;
    outcome.cached = true;
    outcome.status = "cached: " + outcome.status;
    outcome.wall_seconds = 0.0;
    outcome.log.clear();
    return outcome;
  }

  // How long the stage ran the last time it ran, whatever its inputs were then.
  std::optional<double> last_seconds(const std::string& key) const {
    const auto it = records_.find(key);
    if (it == records_.end() || !(it->second.outcome.wall_seconds > 0.0)) return std::nullopt;
    return it->second.outcome.wall_seconds;
  }

  void store(const std::string& key, const std::string& inputs, const StageOutcome& outcome,
             const std::vector<fs::path>& outputs, Digests& digests) {
    CacheRecord record{inputs, outcome, {}};
    for (const auto& f : outputs) {
      if (!fs::is_regular_file(f)) continue;
      digests.forget(f);
      record.outputs[f.string()] = digests.of_file(f);
    }
    records_[key] = std::move(record);
    save();
  }

 private:
  void save() const {
    nlohmann::json stages = nlohmann::json::object();
    for (const auto& [key, r] : records_) {
      stages[key] = {{"inputs", r.inputs},
                     {"status", r.outcome.status},
                     {"failed", r.outcome.failed},
                     {"held_back", r.outcome.held_back},
                     {"exit_code", r.outcome.exit_code},
                     {"message", r.outcome.message},
                     {"command", r.outcome.command},
                     {"report", r.outcome.report.string()},
                     {"regression", r.outcome.regression.string()},
                     {"night", r.outcome.night},
                     {"wall_seconds", r.outcome.wall_seconds},
                     {"outputs", r.outputs}};
    }
    trainer::write_json_atomically(path_, {{"stages", stages}});
  }

  fs::path path_;
  std::map<std::string, CacheRecord> records_;
};

StageOutcome outcome_of(std::string kind, std::string name) {
  StageOutcome outcome;
  outcome.kind = std::move(kind);
  outcome.name = std::move(name);
  return outcome;
}

std::string today_utc() {
  const std::string now = io::utc_now();  // 2026-11-22T00:18:36Z
  return now.substr(0, 10);
}

class Night {
 public:
  Night(const NightlyPlan& plan, const NightlyOptions& options)
      : plan_(plan),
        options_(options),
        registry_(plan.registry),
        cache_(plan.registry / ".registry" / "nightly-cache.json"),
        night_(options.night.empty() ? today_utc() : options.night),
        folder_(options.reports / night_) {
    fs::create_directories(folder_ / "logs");
  }

  ~Night() {
    if (lock_ >= 0) ::close(lock_);
  }
  Night(const Night&) = delete;
  Night& operator=(const Night&) = delete;

  NightlyResult run() {
    const auto start = std::chrono::steady_clock::now();
    // One nightly per registry at a time; the lock dies with the process (kill -9 included).
    fs::create_directories(plan_.registry / ".registry");
    lock_ =
        ::open((plan_.registry / ".registry" / "lock").c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (lock_ < 0 || ::flock(lock_, LOCK_EX | LOCK_NB) != 0) {
      throw std::runtime_error("another nightly holds the registry " + plan_.registry.string() +
                               " (" + (plan_.registry / ".registry" / "lock").string() + ")");
    }
    remove_stale_temporaries();
    for (const auto& repaired : registry_.repair()) {
      std::cerr << "imm-train: restored " << repaired << " from the registry archive\n";
    }
    bool swept = false;
    for (const NightlyStage& stage : plan_.stages) {
      if (stage.kind == "data" || stage.kind == "track") run_plain(stage);
      if (stage.kind != "model") continue;
      // The data stages are done (they come first): every candidate can train now.
      if (options_.sweep && !swept) train_in_sweep();
      swept = true;
      run_model(stage);
    }
    NightlyResult result;
    result.stages = outcomes_;
    result.training = training_;
    result.report_folder = folder_;
    bool failed = false, held_back = false;
    for (const auto& o : outcomes_) failed |= o.failed, held_back |= o.held_back;
    result.exit_code = failed      ? support::exit_code::kJobFailed
                       : held_back ? support::exit_code::kRegression
                                   : 0;
    result.wall_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
  }

 private:
  fs::path tool(const NightlyStage& stage) const { return options_.tools / stage.executable; }

  fs::path log_stem(const std::string& name) const {
    std::string file = name;
    for (char& c : file) {
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
    }
    return folder_ / "logs" / file;
  }

  // Runs a process with its output in the night's logs; echoes its stdout (the tables).
  int spawn(const fs::path& executable, const std::vector<std::string>& arguments,
            const fs::path& log, double& seconds) {
    const auto start = std::chrono::steady_clock::now();
    int code = 0;
    try {
      code = support::run_process(executable, arguments, log);
    } catch (const std::exception& error) {
      std::ofstream(log.string() + ".err") << error.what() << '\n';
      code = 127;
    }
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    echo(log.string() + ".out");
    return code;
  }

  void finish(StageOutcome outcome) {
    if (outcome.night.empty()) outcome.night = night_;
    if (options_.on_finish) options_.on_finish(outcome);
    outcomes_.push_back(std::move(outcome));
  }

  void run_plain(const NightlyStage& stage) {
    const std::string key = stage.kind + ":" + stage.name;
    const std::string inputs = inputs_digest(stage, tool(stage), digests_);
    if (!options_.force) {
      if (auto cached = cache_.find(key, inputs, digests_)) {
        cached->kind = stage.kind, cached->name = stage.name;
        return finish(*cached);
      }
    }
    for (const auto& folder : stage.output_folders) fs::create_directories(folder);
    StageOutcome o = outcome_of(stage.kind, stage.name);
    o.command = command_line(tool(stage), stage.arguments);
    o.log = log_stem(stage.kind + "_" + stage.name);
    o.exit_code = spawn(tool(stage), stage.arguments, o.log, o.wall_seconds);
    o.failed = o.exit_code != 0;
    o.status = o.failed ? "failed" : "ok";
    if (o.failed)
      o.message =
          "exit code " + std::to_string(o.exit_code) + ": " + tail_of(o.log.string() + ".err");
    std::vector<fs::path> outputs = {stage.out};
    for (std::size_t i = 1; i < stage.arguments.size(); ++i) {
      if (stage.arguments[i - 1] == "--csv") outputs.emplace_back(stage.arguments[i]);
    }
    cache_.store(key, inputs, o, outputs, digests_);
    finish(o);
  }

  // The evaluation's arguments with another model file, report folder and (optionally) regime.
  static std::vector<std::string> evaluation_arguments(const NightlyStage& e, const fs::path& model,
                                                       const fs::path& out,
                                                       const std::optional<fs::path>& regime) {
    std::vector<std::string> arguments = e.arguments;
    arguments[*e.model_argument] = model.string();
    arguments[*e.out_argument] = out.string();
    if (regime && !e.has_regime) arguments.insert(arguments.end(), {"--regime", regime->string()});
    return arguments;
  }

  // A model stage's cache key and inputs: its own and those of the evaluations that name it.
  std::pair<std::string, std::string> model_inputs(const NightlyStage& stage) {
    std::vector<std::string> evaluation_texts;
    for (const NightlyStage* e : plan_.evaluations_of(stage.name)) {
      evaluation_texts.push_back(inputs_digest(*e, tool(*e), digests_, {}, plan_outputs()));
    }
    return {"model:" + stage.name, inputs_digest(stage, tool(stage), digests_, evaluation_texts)};
  }

  // Where a model stage's candidate is trained.
  fs::path staging_of(const NightlyStage& stage) const {
    return registry_.staging_folder() / stage.out.lexically_relative(plan_.registry);
  }

  // The stage's arguments with the candidate as its output.
  std::vector<std::string> candidate_arguments(const NightlyStage& stage) const {
    std::vector<std::string> arguments = stage.arguments;
    arguments[*stage.out_argument] = staging_of(stage).string();
    return arguments;
  }

  // Trains every model stage that is not cached in one `imm-train sweep` (NightlyOptions::sweep),
  // each into its staging file with its log where its own stage would put it. What the sweep
  // reports is taken by run_model; a training it does not report on is trained there as usual.
  void train_in_sweep() {
    std::vector<const NightlyStage*> stages;
    for (const NightlyStage& stage : plan_.stages) {
      if (stage.kind != "model") continue;
      const auto [key, inputs] = model_inputs(stage);
      if (options_.force || !cache_.find(key, inputs, digests_)) stages.push_back(&stage);
    }
    // Longest first, by what each took the last time (one never run counts as the longest):
    // the sweep hands jobs out in plan order, so a long training started last would leave the
    // other ranks idle while it finishes.
    const auto cost = [this](const NightlyStage* stage) {
      return cache_.last_seconds("model:" + stage->name)
          .value_or(std::numeric_limits<double>::infinity());
    };
    std::stable_sort(
        stages.begin(), stages.end(),
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

  void run_model(const NightlyStage& stage) {
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
    const fs::path shipped_file = stage.out;
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
    auto conclude = [&](const StageOutcome& m) {
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
      return conclude(model);
    }
    // The candidate's own evaluations (its quality gates), then the shipped model's on the same
    // tracks and the regression comparison.
    const bool comparable_shipped = fs::exists(shipped_file);
    std::vector<std::string> regressions, gate_failures, comparisons;
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
      if (o.exit_code == support::exit_code::kEvaluationGateFailed) {
        o.failed = true;
        o.status = "gate failed";
        o.message = "quality gate failed: " + gate_lines(o.log.string() + ".out");
        gate_failures.push_back(e->name);
      } else if (o.exit_code != 0) {
        o.failed = true;
        o.status = "failed";
        o.message =
            "exit code " + std::to_string(o.exit_code) + ": " + tail_of(o.log.string() + ".err");
        gate_failures.push_back(e->name);
      } else {
        o.status = "ok";
      }
      if (!o.failed && comparable_shipped) {
        const fs::path shipped_out =
            registry_.staging_folder() / "shipped" /
            (stage.name + "_" + std::to_string(evaluation_outcomes.size()));
        fs::create_directories(shipped_out);
        const auto shipped_arguments = evaluation_arguments(*e, shipped_file, shipped_out, staging);
        const fs::path shipped_log = o.log.string() + "_shipped";
        const int shipped_code = spawn(tool(*e), shipped_arguments, shipped_log, o.wall_seconds);
        if (shipped_code == 0 || shipped_code == support::exit_code::kEvaluationGateFailed) {
          const std::vector<std::string> compare = {
              "regression",         "--candidate", e->out.string(), "--shipped",
              shipped_out.string(), "--out",       e->out.string()};
          const fs::path compare_log = o.log.string() + "_regression";
          const int verdict =
              spawn(options_.tools / "imm-eval", compare, compare_log, o.wall_seconds);
          model.regression = e->out / "regression.json";
          if (verdict == support::exit_code::kRegression) {
            regressions.push_back(e->name + ": " + tail_of(compare_log.string() + ".out", 8));
          } else if (verdict != 0) {
            comparisons.push_back(e->name + ": not compared (" +
                                  tail_of(compare_log.string() + ".err", 2) + ")");
          }
        } else {
          comparisons.push_back(e->name +
                                ": the shipped model could not be evaluated on the "
                                "candidate's regime (" +
                                tail_of(shipped_log.string() + ".err", 2) +
                                "): promoted on its own gates");
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
      registry_.promote(entry, staging, trainer::metrics_path(staging));
      model.status = had_entry ? "promoted" : "promoted (first in the manifest)";
      model.message = comparisons.empty() ? "" : join(comparisons);
      fs::remove(staging);
      fs::remove(trainer::metrics_path(staging));
    } catch (const std::exception& error) {
      model.failed = true;
      model.status = "failed";
      model.message = std::string("promotion failed: ") + error.what();
    }
    conclude(model);
  }

  // Temporary files of a run that was killed (".<name>.tmp-<pid>" beside models, archive entries,
  // the manifest and the cache), and its staged candidates.
  void remove_stale_temporaries() const {
    std::error_code error;
    for (const auto& f : fs::recursive_directory_iterator(plan_.registry, error)) {
      const std::string name = f.path().filename().string();
      if (f.is_regular_file() && name.starts_with(".") && name.find(".tmp-") != std::string::npos) {
        fs::remove(f.path(), error);
      }
    }
    fs::remove_all(registry_.staging_folder(), error);
  }

  // The plan's model stages by output file, as their own inputs digest (without evaluations).
  PlanOutputs plan_outputs() {
    PlanOutputs outputs;
    for (const NightlyStage& s : plan_.stages) {
      if (s.kind == "model") outputs[normal_path(s.out)] = inputs_digest(s, tool(s), digests_);
    }
    return outputs;
  }

  static std::string join(const std::vector<std::string>& parts) {
    std::string text;
    for (const auto& p : parts) text += (text.empty() ? "" : "; ") + p;
    return text;
  }

  // The headline metrics of the candidate's evaluations, with the regression intervals when the
  // shipped model was compared.
  static nlohmann::json headline_metrics(const std::vector<const NightlyStage*>& evaluations) {
    nlohmann::json metrics = nlohmann::json::object();
    for (const NightlyStage* e : evaluations) {
      const fs::path headline = e->out / "headline.json";
      if (!fs::exists(headline)) continue;
      const auto document = nlohmann::json::parse(trainer::read_text_file(headline));
      std::map<std::string, nlohmann::json> versus;
      if (fs::exists(e->out / "regression.json")) {
        const auto regression =
            nlohmann::json::parse(trainer::read_text_file(e->out / "regression.json"));
        for (const auto& m : regression.at("metrics")) versus[m.at("name")] = m;
      }
      for (const auto& m : document.at("metrics")) {
        const std::string name = e->name + ": " + m.at("name").get<std::string>();
        nlohmann::json entry = {{"value", m.at("value")},
                                {"interval", m.value("interval", nlohmann::json::array())}};
        const auto it = versus.find(m.at("name").get<std::string>());
        if (it != versus.end()) {
          std::ostringstream text;
          text.precision(4);
          text << std::showpos << it->second.at("difference").get<double>() << " ["
               << it->second.at("lower").get<double>() << ", "
               << it->second.at("upper").get<double>() << "]";
          entry["versus_previous"] = text.str();
        }
        metrics[name] = entry;
      }
    }
    return metrics;
  }

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

}  // namespace

NightlyResult run_nightly(const NightlyPlan& plan, const NightlyOptions& options) {
  Night night(plan, options);
  NightlyResult result = night.run();
  write_morning_report(result.report_folder, plan, result);
  return result;
}

}  // namespace imm::pipeline
