// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/sweep.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <iterator>
#include <map>
#include <sstream>

#include "imm/support/config.hpp"
#include "imm/trainer/ranks.hpp"

namespace imm::trainer {
namespace {

const std::vector<std::string>& kinds() {
  static const std::vector<std::string> names{"ga", "mlp", "wimm", "fcm", "tsk"};
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

}  // namespace

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
      const std::string kind = entry.text("kind");
      if (std::find(kinds().begin(), kinds().end(), kind) == kinds().end()) {
        entry.fail("kind", "'" + kind + "' is not a training kind (ga, mlp, wimm, fcm, tsk)");
      }
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
      if (!entry.has("regimes") && out.find("{regime}") != std::string::npos) {
        entry.fail("out", "names {regime}, but the job lists no regimes");
      }
      if (!entry.has("seeds") && out.find("{seed}") != std::string::npos) {
        entry.fail("out", "names {seed}, but the job lists no seeds");
      }
      for (const auto& regime : regimes) {
        for (const auto& seed : seeds) {
          SweepJob job;
          job.kind = kind;
          job.config = config;
          job.regime = regime;
          job.seed = seed;
          std::string file = replaced(out, "{kind}", kind);
          if (regime) file = replaced(file, "{regime}", regime->stem().string());
          if (seed) file = replaced(file, "{seed}", std::to_string(*seed));
          job.out = file;
          job.name = kind + " " + config.stem().string();
          if (regime) job.name += ", regime " + regime->stem().string();
          if (seed) job.name += ", seed " + std::to_string(*seed);
          if (const auto [it, fresh] = outputs.emplace(file, job.name); !fresh) {
            entry.fail("out", "'" + job.name + "' and '" + it->second + "' both write " + file);
          }
          plan.jobs.push_back(std::move(job));
        }
      }
    }
    return plan;
  });
}

std::vector<SweepOutcome> run_sweep(
    const SweepPlan& plan, const SweepTraining& train,
    const std::function<void(const SweepJob&, const SweepOutcome&)>& on_done) {
  const Ranks& ranks = Ranks::world();
  JobQueue queue(ranks, static_cast<long>(plan.jobs.size()));
  long job = -1;
  std::string result;
  while ((job = queue.next(job, result)) >= 0) {
    const SweepJob& current = plan.jobs[static_cast<std::size_t>(job)];
    SweepOutcome outcome;
    outcome.rank = ranks.rank();
    const auto start = std::chrono::steady_clock::now();
    try {
      // The job trains by itself: a GA inside it spreads over this rank's threads only.
      const AloneInTheJob alone;
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

}  // namespace imm::trainer
