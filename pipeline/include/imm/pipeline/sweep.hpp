// SPDX-License-Identifier: Apache-2.0
#pragma once
/// `imm-train sweep`: many trainings (kind × regime × seed) handed out to the ranks of an mpirun
/// or srun job as they become free (JobQueue), or run one after the other without MPI. Each
/// training is the same as its subcommand's, writes its model atomically, and trains alone (its
/// GA uses its rank's OpenMP threads, not the other ranks). A failing job is reported and the
/// others go on; the root prints one summary.
///
/// The plan (TOML):
///
///     [[jobs]]
///     kind = "ga"                         # ga | mlp | wimm | fcm | tsk | baseline | schedule
///     config = "configs/ga_fuzzy_imm.toml"
///     regimes = ["configs/regimes/…", …]  # optional: the config's own regime when absent
///     seeds = [1, 2, 3]                   # optional: the config's seed when absent
///     out = "sweep/ga_{regime}_{seed}.h5" # {regime}: the regime file's stem; {seed}; {kind}
///
/// Each [[jobs]] entry stands for every regime × seed it lists; two jobs may not write one file.
///
/// Or one training as its imm-train arguments (how the nightly hands its stages to a sweep):
///
///     [[jobs]]
///     name = "ga_fuzzy_imm"               # optional: how the summary names it
///     command = ["ga", "--config", "configs/ga_fuzzy_imm.toml", "--out", "models/x.h5"]
///
/// `command` starts with a subcommand that writes one model file (training_commands.hpp: the
/// training kinds above, freeze, import-rules) and gives its `--out`. Either form may add
///
///     log = "logs/{kind}_{regime}_{seed}"  # the training's stdout and stderr go to LOG.out and
///                                          # LOG.err instead of the job's

#include <cstdint>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace imm::pipeline {

struct SweepJob {
  std::string name;  ///< "ga seed 3, regime agile_air": how the summary names it
  std::string kind;  ///< the imm-train subcommand (arguments.front())
  /// The imm-train arguments that run it: the subcommand first (`ga --config … --out …`).
  std::vector<std::string> arguments;
  std::filesystem::path out;
  std::optional<std::filesystem::path> log;  ///< stdout to log.out, stderr to log.err
};

struct SweepPlan {
  std::filesystem::path file;
  std::vector<SweepJob> jobs;
};

/// Reads and checks a sweep plan; a bad one is a support::ConfigError naming the key.
[[nodiscard]] SweepPlan load_sweep_plan(const std::filesystem::path& path);

struct SweepOutcome {
  int exit_code = 0;  ///< the training's own (0 written, 2 bad input, 4 gate failed, …)
  int rank = 0;       ///< which rank ran it
  double seconds = 0.0;
  std::string message;  ///< the error, when it failed
};

/// Runs one job as its subcommand would; returns the subcommand's exit code or throws.
using SweepTraining = std::function<int(const SweepJob&)>;

/// The subcommands a job may run (they write one model file each).
[[nodiscard]] const std::vector<std::string>& sweep_subcommands();

/// Runs every job of `plan` over the job's ranks (a job with a log writes its output there). On the
/// root: every job's outcome, by job (the other ranks get an empty list). `on_done` is called on
/// the rank that ran each job.
[[nodiscard]] std::vector<SweepOutcome> run_sweep(
    const SweepPlan& plan, const SweepTraining& train,
    const std::function<void(const SweepJob&, const SweepOutcome&)>& on_done = {});

/// The root's summary of a sweep (`imm-train sweep --summary FILE`): the plan, the ranks, the
/// seconds, and every job's name, out, log, exit code, rank, seconds and message, by job.
[[nodiscard]] nlohmann::json sweep_summary(const SweepPlan& plan,
                                           const std::vector<SweepOutcome>& outcomes, int ranks,
                                           double seconds);

}  // namespace imm::pipeline
