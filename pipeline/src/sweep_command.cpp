// SPDX-License-Identifier: Apache-2.0
// `imm-train sweep`: a plan's trainings, each an imm-train command line, handed out over the
// ranks (training_commands.hpp).
#include <spdlog/fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <set>
#include <stdexcept>

#include "imm/pipeline/training_commands.hpp"
#include "imm/support/config.hpp"
#include "imm/support/exit_codes.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/ranks.hpp"
#include "imm/trainer/temporaries_guard.hpp"

namespace imm::pipeline {

namespace exit_code = support::exit_code;

void parse_job(CLI::App& app, const SweepJob& job) {
  app.require_subcommand(1);
  std::vector<std::string> reversed(job.arguments.rbegin(), job.arguments.rend());
  app.parse(reversed);  // CLI11 takes a vector in reverse order
}

int train_job(const SweepJob& job, int real_rank) {
  CLI::App app{"imm-train"};
  const TrainingCommands training(app);
  try {
    parse_job(app, job);
  } catch (const CLI::ParseError& error) {
    throw std::invalid_argument(job.name + ": " + error.what());
  }
  if (!job.log) return training.run();
  log_as(0);
  try {
    const int code = training.run();
    log_as(real_rank);
    return code;
  } catch (const std::exception& error) {
    spdlog::error("{}", error.what());  // into the job's log, as its subcommand would
    log_as(real_rank);
    throw;
  } catch (...) {
    log_as(real_rank);
    throw;
  }
}

int run_sweep_command(const std::filesystem::path& plan_file,
                      const std::optional<std::filesystem::path>& summary) {
  const trainer::Ranks& ranks = trainer::Ranks::world();
  const auto plan = load_sweep_plan(plan_file);
  // Every job's arguments must be its subcommand's command line before anything trains.
  for (std::size_t i = 0; i < plan.jobs.size(); ++i) {
    CLI::App app{"imm-train"};
    const TrainingCommands training(app);
    try {
      parse_job(app, plan.jobs[i]);
    } catch (const CLI::ParseError& error) {
      throw support::ConfigError(plan_file.string(), "jobs",
                                 fmt::format("'{}' is not an imm-train command line: {}",
                                             plan.jobs[i].name, error.what()));
    }
  }
  // One temporaries guard for every output folder of the plan (see temporaries_guard.hpp).
  std::set<std::filesystem::path> folders;
  for (const auto& job : plan.jobs) {
    folders.insert(job.out.parent_path().empty() ? "." : job.out.parent_path());
  }
  trainer::guard_temporaries({folders.begin(), folders.end()});
  spdlog::info("sweep {}: {} trainings over {} rank{}", plan_file.string(), plan.jobs.size(),
               ranks.size(), ranks.size() == 1 ? "" : "s");
  const auto start = std::chrono::steady_clock::now();
  const int rank = ranks.rank();
  const auto outcomes = run_sweep(
      plan, [rank](const SweepJob& job) { return train_job(job, rank); },
      [&](const SweepJob& job, const SweepOutcome& o) {
        if (o.exit_code != 0) {
          spdlog::warn("sweep: {} failed on rank {}: {}", job.name, o.rank, o.message);
        }
      });
  if (!ranks.root()) return 0;
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::vector<std::string> failed;
  for (std::size_t i = 0; i < outcomes.size(); ++i) {
    const auto& o = outcomes[i];
    const auto& job = plan.jobs[i];
    if (o.exit_code == 0) {
      spdlog::info("sweep: {} -> {} (rank {}, {:.1f} s)", job.name, job.out.string(), o.rank,
                   o.seconds);
    } else {
      spdlog::error("sweep: {} FAILED (rank {}, {:.1f} s): {}{}", job.name, o.rank, o.seconds,
                    o.message, job.log ? " (log " + job.log->string() + ".err)" : "");
      failed.push_back(job.name);
    }
  }
  if (summary) {
    trainer::write_json_atomically(*summary, sweep_summary(plan, outcomes, ranks.size(), seconds));
  }
  if (!failed.empty()) {
    spdlog::error("sweep: {} of {} trainings failed in {:.1f} s: {}", failed.size(),
                  outcomes.size(), seconds, fmt::join(failed, "; "));
    return exit_code::kJobFailed;
  }
  spdlog::info("sweep: {} trainings in {:.1f} s", outcomes.size(), seconds);
  return 0;
}

}  // namespace imm::pipeline
