// SPDX-License-Identifier: Apache-2.0
#include "nightly_run.hpp"

// The nightly run: stages, the candidate → evaluation → regression → promotion path of each
// model, the stage cache, and the exit code (see imm/pipeline/nightly.hpp).

#include <fcntl.h>
#include <sys/file.h>
#include <toml++/toml.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string_view>

#include "imm/datasets/sha256.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/temporary_files.hpp"
#include "imm/pipeline/nightly.hpp"
#include "imm/pipeline/registry.hpp"
#include "imm/support/exit_codes.hpp"
#include "imm/support/process.hpp"
#include "imm/trainer/provenance.hpp"
#include "nightly_trends.hpp"

namespace imm::pipeline {
namespace {

std::string today_utc() {
  const std::string now = io::utc_now();  // 2026-11-22T00:18:36Z
  return now.substr(0, 10);
}

}  // namespace

std::string command_line(const fs::path& tool, const std::vector<std::string>& arguments) {
  std::string text = tool.filename().string();
  for (const auto& a : arguments) {
    text += ' ';
    text += a.find_first_of(" \"'") == std::string::npos ? a : "'" + a + "'";
  }
  return text;
}

std::string tail_of(const fs::path& file, std::size_t lines) {
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

namespace {

// The block of `file` that opens with a line starting with `heading` and goes on with "  - " lines.
std::string block_of(const fs::path& file, std::string_view heading) {
  std::ifstream in(file);
  std::string text;
  bool inside = false;
  for (std::string line; std::getline(in, line);) {
    if (line.starts_with(heading)) {
      inside = true;
      text += (text.empty() ? "" : "\n") + line;
    } else if (inside && line.starts_with("  - ")) {
      text += "\n" + line;
    } else {
      inside = false;
    }
  }
  return text;
}

}  // namespace

std::string gate_lines(const fs::path& file) {
  std::string text = block_of(file, "Gates");
  return text.empty() ? tail_of(file, 3) : text;
}

std::vector<std::string> failed_gates(const fs::path& file) {
  std::vector<std::string> failed;
  std::istringstream lines(block_of(file, "Gates"));
  for (std::string line; std::getline(lines, line);) {
    if (line.starts_with("  - ")) failed.push_back(line.substr(4));
  }
  return failed;
}

std::vector<std::string> unknown_failures(const std::vector<std::string>& failed,
                                          const std::vector<KnownFailure>& known) {
  std::vector<std::string> unknown;
  for (const std::string& line : failed) {
    if (std::none_of(known.begin(), known.end(),
                     [&](const KnownFailure& k) { return k.accepts(line); })) {
      unknown.push_back(line);
    }
  }
  return unknown;
}

std::string known_reasons(const std::vector<std::string>& failed,
                          const std::vector<KnownFailure>& known) {
  std::string text;
  for (const KnownFailure& k : known) {
    if (std::any_of(failed.begin(), failed.end(),
                    [&](const std::string& line) { return k.accepts(line); })) {
      text += (text.empty() ? "known: " : "; ") + k.reason;
    }
  }
  return text;
}

std::string findings_lines(const fs::path& file) {
  std::string text = block_of(file, "Findings");
  return text.empty() ? tail_of(file, 3) : text;
}

bool out_of_room(const std::string& message) {
  for (const char* words : {"No space left on device", "File too large", "Disk quota exceeded"}) {
    if (message.find(words) != std::string::npos) return true;
  }
  return false;
}

void echo(const fs::path& file) {
  std::ifstream in(file);
  // An empty file would set failbit on std::cout and silence everything after it.
  if (in.peek() == std::ifstream::traits_type::eof()) return;
  std::cout << in.rdbuf();
  std::cout.flush();
}

StageOutcome outcome_of(std::string kind, std::string name) {
  StageOutcome outcome;
  outcome.kind = std::move(kind);
  outcome.name = std::move(name);
  return outcome;
}

Night::Night(const NightlyPlan& plan, const NightlyOptions& options)
    : plan_(plan),
      options_(options),
      registry_(plan.registry),
      cache_(plan.registry / ".registry" / "nightly-cache.json"),
      night_(options.night.empty() ? today_utc() : options.night),
      folder_(options.reports / night_) {
  fs::create_directories(folder_ / "logs");
}

Night::~Night() {
  if (lock_ >= 0) ::close(lock_);
}

NightlyResult Night::run() {
  const auto start = std::chrono::steady_clock::now();
  // One nightly per registry at a time; the lock dies with the process (kill -9 included). (Each
  // change of the manifest also holds the registry's own lock, registry.cpp, for its duration:
  // a rollback or a promotion by hand during a night is kept.)
  fs::create_directories(plan_.registry / ".registry");
  const fs::path night_lock = plan_.registry / ".registry" / "nightly.lock";
  lock_ = ::open(night_lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lock_ < 0) {
    throw std::runtime_error(night_lock.string() +
                             ": cannot open the nightly's lock: " + std::strerror(errno));
  }
  if (::flock(lock_, LOCK_EX | LOCK_NB) != 0) {
    throw std::runtime_error(errno == EWOULDBLOCK
                                 ? "another nightly holds the registry " + plan_.registry.string() +
                                       " (" + night_lock.string() + ")"
                                 : night_lock.string() + ": cannot lock: " + std::strerror(errno));
  }
  remove_stale_temporaries();
  for (const auto& repaired : registry_.repair()) {
    std::cerr << "imm-train: restored " << repaired << " from the registry archive\n";
  }
  bool swept = false;
  for (const NightlyStage& stage : plan_.stages) {
    // A stage that cannot even start (a tool binary or a file it reads is missing or unreadable,
    // so its inputs have no digest) fails alone; the others run and the report is written.
    try {
      if (stage.kind == "data" || stage.kind == "track") run_plain(stage);
      if (stage.kind == "tracker") run_tracker(stage);
      if (stage.kind != "model") continue;
      // The data stages are done (they come first): every candidate can train now.
      if (options_.sweep && !swept) train_in_sweep();
      swept = true;
      run_model(stage);
    } catch (const std::exception& error) {
      StageOutcome o = outcome_of(stage.kind, stage.name);
      o.failed = true;
      o.transient = true;
      o.status = "failed";
      o.command = command_line(tool(stage), stage.arguments);
      o.message = std::string("the stage could not run: ") + error.what();
      std::cerr << "imm-train: " << stage.kind << " " << stage.name << ": " << o.message << '\n';
      finish(o);
    }
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

fs::path Night::log_stem(const std::string& name) const {
  std::string file = name;
  for (char& c : file) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  }
  return folder_ / "logs" / file;
}

int Night::spawn(const fs::path& executable, const std::vector<std::string>& arguments,
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

void Night::finish(StageOutcome outcome) {
  if (outcome.night.empty()) outcome.night = night_;
  if (options_.on_finish) options_.on_finish(outcome);
  outcomes_.push_back(std::move(outcome));
}

void Night::run_plain(const NightlyStage& stage) {
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
  if (o.failed) {
    o.message =
        "exit code " + std::to_string(o.exit_code) + ": " + tail_of(o.log.string() + ".err");
    o.transient = out_of_room(o.message);
  }
  std::vector<fs::path> outputs;
  std::error_code error;
  for (const fs::path& output : stage.outputs) {
    outputs.push_back(output);
    if (fs::is_directory(output, error)) {  // an export's recordings
      for (const auto& f : fs::directory_iterator(output, error)) outputs.push_back(f.path());
    }
  }
  cache_.store(key, inputs, o, outputs, digests_);
  finish(o);
}

void Night::remove_stale_temporaries() const {
  std::error_code error;
  for (const auto& f : fs::recursive_directory_iterator(plan_.registry, error)) {
    // Only this host's temporaries of dead processes: another user's imm-train running now, or a
    // rank on another node of a shared folder, is writing its own.
    if (f.is_regular_file() && io::is_stale_temporary(f.path().filename().string())) {
      fs::remove(f.path(), error);
    }
  }
  fs::remove_all(registry_.staging_folder(), error);
}

PlanOutputs Night::plan_outputs() {
  PlanOutputs outputs;
  for (const NightlyStage& s : plan_.stages) {
    if (s.kind != "model") continue;
    try {
      outputs[normal_path(s.out)] = inputs_digest(s, tool(s), digests_);
    } catch (const std::exception& error) {
      // That stage fails on its own; the others' digests name what it would have read.
      outputs[normal_path(s.out)] = std::string("unreadable: ") + error.what();
    }
  }
  return outputs;
}

std::string Night::join(const std::vector<std::string>& parts) {
  std::string text;
  for (const auto& p : parts) text += (text.empty() ? "" : "; ") + p;
  return text;
}

NightlyResult run_nightly(const NightlyPlan& plan, const NightlyOptions& options) {
  Night night(plan, options);
  NightlyResult result = night.run();
  record_night(result.report_folder.parent_path() / "nights.jsonl",
               result.report_folder.filename().string(), result);
  write_morning_report(result.report_folder, plan, result);
  if (plan.evaluations_page) write_evaluations_page(*plan.evaluations_page, plan, result);
  return result;
}

}  // namespace imm::pipeline
