// SPDX-License-Identifier: Apache-2.0
#include "imm/pipeline/sweep.hpp"

#include <fcntl.h>
#include <spdlog/fmt/ranges.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iostream>
#include <iterator>
#include <map>
#include <optional>
#include <sstream>

#include "imm/pipeline/training_commands.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/ranks.hpp"

namespace imm::pipeline {
namespace {

// The commands of training_kinds(): those taking a training's options, or all of them.
std::vector<std::string> training_commands(bool training_options_only) {
  std::vector<std::string> names;
  for (const TrainingKind& kind : training_kinds()) {
    if (kind.training_options || !training_options_only) names.push_back(kind.command);
  }
  return names;
}

std::string replaced(std::string text, const std::string& field, const std::string& value) {
  for (auto at = text.find(field); at != std::string::npos; at = text.find(field, at)) {
    text.replace(at, field.size(), value);
    at += value.size();
  }
  return text;
}

/// "<exit code> <rank> <seconds> <message>": one job's outcome as the queue carries it.
std::string encode(const SweepOutcome& outcome) {
  std::ostringstream text;
  text.precision(17);
  text << outcome.exit_code << ' ' << outcome.rank << ' ' << outcome.seconds << ' '
       << outcome.message;
  return text.str();
}

SweepOutcome decode(const std::string& text) {
  SweepOutcome outcome;
  std::istringstream in(text);
  if (!(in >> outcome.exit_code >> outcome.rank >> outcome.seconds)) {
    return {-1, -1, 0.0, "no result was reported"};
  }
  in.get();
  std::getline(in, outcome.message, '\0');
  return outcome;
}

/// While alive, this process's stdout and stderr go to `log`.out and `log`.err (created or
/// truncated); both come back when it ends. Whatever this process writes meanwhile goes there:
/// in a sweep only the job's training writes (the root's dispatcher thread prints nothing).
class OutputToLog {
 public:
  explicit OutputToLog(const std::filesystem::path& log) {
    if (log.has_parent_path()) std::filesystem::create_directories(log.parent_path());
    flush();
    for (int i = 0; i < 2; ++i) {
      const std::string file = log.string() + (i == 0 ? ".out" : ".err");
      const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
      if (fd < 0) {
        restore();
        throw std::runtime_error("cannot write the job's log " + file + ": " +
                                 std::strerror(errno));
      }
      saved_[i] = ::dup(i + 1);
      ::dup2(fd, i + 1);
      ::close(fd);
    }
  }
  ~OutputToLog() { restore(); }
  OutputToLog(const OutputToLog&) = delete;
  OutputToLog& operator=(const OutputToLog&) = delete;

 private:
  static void flush() {
    std::cout.flush();
    std::cerr.flush();
    std::fflush(stdout);
    std::fflush(stderr);
  }
  void restore() {
    flush();
    for (int i = 0; i < 2; ++i) {
      if (saved_[i] < 0) continue;
      ::dup2(saved_[i], i + 1);
      ::close(saved_[i]);
      saved_[i] = -1;
    }
  }
  int saved_[2] = {-1, -1};
};

// A [[jobs]] entry of the kind × regimes × seeds form: one job for each regime and seed.
std::vector<SweepJob> expand_jobs(const support::ConfigTable& entry) {
  const TrainingKind* training = find_training_kind(entry.text("kind"));
  if (training == nullptr) {
    entry.fail("kind", fmt::format("'{}' is not a training kind ({}, or their model kinds' names)",
                                   entry.text("kind"), fmt::join(training_commands(true), ", ")));
  }
  const std::string& kind = training->command;
  const std::filesystem::path config = entry.text("config");
  if (!std::filesystem::is_regular_file(config)) {
    entry.fail("config", "no such config file: " + config.string());
  }
  std::vector<std::optional<std::filesystem::path>> regimes;
  if (entry.has("regimes")) {
    const std::vector<std::string> listed = entry.texts("regimes");
    regimes.assign(listed.begin(), listed.end());
    if (regimes.empty()) entry.fail("regimes", "an empty list (leave it out for the config's)");
  } else {
    regimes.emplace_back(std::nullopt);
  }
  std::vector<std::optional<std::uint64_t>> seeds;
  if (entry.has("seeds")) {
    for (double seed : entry.reals("seeds")) {
      if (!(seed >= 0.0) || seed != std::floor(seed) || seed > 9.0e15) {
        entry.fail("seeds", "seeds are non-negative integers");
      }
      seeds.emplace_back(static_cast<std::uint64_t>(seed));
    }
    if (seeds.empty()) entry.fail("seeds", "an empty list (leave it out for the config's)");
  } else {
    seeds.emplace_back(std::nullopt);
  }
  const std::string out = entry.text("out");
  const std::optional<std::string> log =
      entry.has("log") ? std::optional<std::string>(entry.text("log")) : std::nullopt;
  for (const auto& [key, pattern] : {std::pair{"out", out}, std::pair{"log", log.value_or("")}}) {
    if (!entry.has("regimes") && pattern.find("{regime}") != std::string::npos) {
      entry.fail(key, "names {regime}, but the job lists no regimes");
    }
    if (!entry.has("seeds") && pattern.find("{seed}") != std::string::npos) {
      entry.fail(key, "names {seed}, but the job lists no seeds");
    }
  }
  std::vector<SweepJob> jobs;
  for (const auto& regime : regimes) {
    for (const auto& seed : seeds) {
      auto fill = [&](std::string text) {
        text = replaced(std::move(text), "{kind}", kind);
        if (regime) text = replaced(std::move(text), "{regime}", regime->stem().string());
        if (seed) text = replaced(std::move(text), "{seed}", std::to_string(*seed));
        return text;
      };
      SweepJob job;
      job.kind = kind;
      job.out = fill(out);
      if (log) job.log = fill(*log);
      job.arguments = {kind, "--config", config.string()};
      if (regime) job.arguments.insert(job.arguments.end(), {"--regime", regime->string()});
      if (seed) job.arguments.insert(job.arguments.end(), {"--seed", std::to_string(*seed)});
      job.arguments.insert(job.arguments.end(), {"--out", job.out.string()});
      job.name = kind + " " + config.stem().string();
      if (regime) job.name += ", regime " + regime->stem().string();
      if (seed) job.name += ", seed " + std::to_string(*seed);
      jobs.push_back(std::move(job));
    }
  }
  return jobs;
}

// A [[jobs]] entry of the command form: one training as its imm-train arguments.
SweepJob command_job(const support::ConfigTable& entry) {
  SweepJob job;
  job.arguments = entry.texts("command");
  if (job.arguments.empty()) entry.fail("command", "an empty command: nothing to train");
  job.kind = job.arguments.front();
  const auto& allowed = sweep_subcommands();
  if (std::find(allowed.begin(), allowed.end(), job.kind) == allowed.end()) {
    entry.fail("command", fmt::format("'{}' is not a subcommand that writes a model file ({})",
                                      job.kind, fmt::join(allowed, ", ")));
  }
  const auto out = std::find(job.arguments.begin(), job.arguments.end(), "--out");
  if (out == job.arguments.end() || std::next(out) == job.arguments.end()) {
    entry.fail("command", "gives no --out FILE: a job must say which model file it writes");
  }
  job.out = *std::next(out);
  job.name = entry.has("name") ? entry.text("name") : job.kind + " " + job.out.string();
  if (entry.has("log")) job.log = entry.text("log");
  return job;
}

}  // namespace

const std::vector<std::string>& sweep_subcommands() {
  static const std::vector<std::string> names = training_commands(false);
  return names;
}

SweepPlan load_sweep_plan(const std::filesystem::path& path) {
  const auto document = support::ConfigDocument::load(path);
  return document->load_checked([&] {
    SweepPlan plan;
    plan.file = path;
    const support::ConfigTable root = document->root();
    const auto entries = root.tables("jobs");
    if (entries.empty()) root.fail("jobs", "no [[jobs]]: nothing to train");
    std::map<std::string, std::string> outputs;  // out → the job writing it
    for (const support::ConfigTable& entry : entries) {
      if (entry.has("command") && entry.has("kind")) {
        entry.fail("command", "a job is either `kind` (with config, regimes, seeds) or `command`");
      }
      const std::vector<SweepJob> jobs =
          entry.has("command") ? std::vector<SweepJob>{command_job(entry)} : expand_jobs(entry);
      for (const SweepJob& job : jobs) {
        if (const auto [it, fresh] = outputs.emplace(job.out.string(), job.name); !fresh) {
          entry.fail(entry.has("command") ? "command" : "out",
                     "'" + job.name + "' and '" + it->second + "' both write " + job.out.string());
        }
        plan.jobs.push_back(job);
      }
    }
    return plan;
  });
}

std::vector<SweepOutcome> run_sweep(
    const SweepPlan& plan, const SweepTraining& train,
    const std::function<void(const SweepJob&, const SweepOutcome&)>& on_done) {
  const trainer::Ranks& ranks = trainer::Ranks::world();
  trainer::JobQueue queue(ranks, static_cast<long>(plan.jobs.size()));
  long job = -1;
  std::string result;
  while ((job = queue.next(job, result)) >= 0) {
    const SweepJob& current = plan.jobs[static_cast<std::size_t>(job)];
    SweepOutcome outcome;
    outcome.rank = ranks.rank();
    const auto start = std::chrono::steady_clock::now();
    try {
      // The job trains by itself: a GA inside it spreads over this rank's threads only.
      const trainer::AloneInTheJob alone;
      const std::optional<OutputToLog> logged =
          current.log ? std::optional<OutputToLog>(std::in_place, *current.log) : std::nullopt;
      outcome.exit_code = train(current);
      if (outcome.exit_code != 0)
        outcome.message = "exit code " + std::to_string(outcome.exit_code);
    } catch (const std::exception& error) {
      outcome.exit_code = 2;
      outcome.message = error.what();
    } catch (...) {
      outcome.exit_code = 2;
      outcome.message = "unexpected error";
    }
    outcome.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (on_done) on_done(current, outcome);
    result = encode(outcome);
  }
  std::vector<SweepOutcome> outcomes;
  if (!ranks.root()) return outcomes;
  const std::vector<std::string> results = queue.results();
  std::transform(results.begin(), results.end(), std::back_inserter(outcomes), decode);
  return outcomes;
}

nlohmann::json sweep_summary(const SweepPlan& plan, const std::vector<SweepOutcome>& outcomes,
                             int ranks, double seconds) {
  nlohmann::json jobs = nlohmann::json::array();
  for (std::size_t i = 0; i < plan.jobs.size() && i < outcomes.size(); ++i) {
    const SweepJob& job = plan.jobs[i];
    const SweepOutcome& o = outcomes[i];
    jobs.push_back({{"name", job.name},
                    {"arguments", job.arguments},
                    {"out", job.out.string()},
                    {"log", job.log ? job.log->string() : ""},
                    {"exit_code", o.exit_code},
                    {"rank", o.rank},
                    {"seconds", o.seconds},
                    {"message", o.message}});
  }
  return {{"plan", plan.file.string()}, {"ranks", ranks}, {"seconds", seconds}, {"jobs", jobs}};
}

}  // namespace imm::pipeline
