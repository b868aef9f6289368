// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The job language of imm-train: the subcommands that write one model file (training_kinds():
/// ga, mlp, wimm, fcm, tsk, baseline, schedule, freeze, import-rules), their command lines and how
/// each runs. imm-train parses its own command line with them, and a sweep (sweep.hpp) parses each
/// job's arguments with the same parser, so a job runs exactly as its subcommand would.

#include <CLI/CLI.hpp>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "imm/pipeline/sweep.hpp"

namespace imm::pipeline {

/// The log of rank `rank`: the root reports progress; the other ranks only what goes wrong on
/// them, their lines marked with their rank.
void log_as(int rank);

/// A training subcommand once added to a command line: what runs it with the options parsed
/// there, and the model file it then writes.
struct TrainingRun {
  std::function<int()> run{};
  std::function<std::filesystem::path()> out{};
};

/// One subcommand of imm-train that writes one model file, described once. imm-train's command
/// line, a sweep's jobs (sweep.hpp) and the Python module's train() find it in training_kinds().
struct TrainingKind {
  /// Its subcommand, e.g. "ga". The model kind's own name (and its other aliases) also name it
  /// where the command is one of the kind's aliases (imm/model_kinds.hpp): "ga_fuzzy_imm".
  std::string command{};
  /// The model kind of the files it writes, e.g. "ga_fuzzy_imm"; empty where the config decides.
  std::string model_kind{};
  /// Its help line.
  std::string about{};
  /// Whether it takes a training's options (--config, --regime, --seed, --out), so that a sweep's
  /// `kind =` job (config × regimes × seeds) can name it.
  bool training_options = true;
  /// Whether it spreads its own work over the ranks of an mpirun (only the GA's generations).
  bool distributed = false;
  /// Adds its options to `command` (its subcommand, already added) and returns what runs it.
  std::function<TrainingRun(CLI::App& command)> add{};
};

/// Every training subcommand, in the order imm-train lists them.
[[nodiscard]] const std::vector<TrainingKind>& training_kinds();

/// The training kind taking a training's options that `name` names: its command, or the name or
/// an alias of the model kind its command is an alias of ("ga_fuzzy_imm", "ga-imm" → ga);
/// nullptr for none.
[[nodiscard]] const TrainingKind* find_training_kind(std::string_view name);

/// The subcommands of training_kinds(), added to `app`: on the command line, and as a sweep's
/// jobs, which run exactly them.
class TrainingCommands {
 public:
  explicit TrainingCommands(CLI::App& app);
  TrainingCommands(const TrainingCommands&) = delete;
  TrainingCommands& operator=(const TrainingCommands&) = delete;

  /// The training the command line chose, if it chose one of these.
  [[nodiscard]] const TrainingKind* chosen() const;

  /// The model file of the subcommand the command line chose, if it chose one of these.
  [[nodiscard]] std::optional<std::filesystem::path> chosen_out() const;

  /// Runs the chosen subcommand, then calibrates the written model's envelope test on its regime
  /// (imm/trainer/model_files/envelope.hpp); its exit code (support/exit_codes.hpp).
  [[nodiscard]] int run() const;

 private:
  struct Added {
    const TrainingKind* kind = nullptr;
    const CLI::App* command = nullptr;
    TrainingRun run{};
  };
  [[nodiscard]] const Added* chosen_added() const;

  std::vector<Added> added_;
};

/// A sweep job's arguments parsed as its subcommand's command line; a CLI::ParseError when they
/// are not one.
void parse_job(CLI::App& app, const SweepJob& job);

/// One job of a sweep, exactly as its subcommand runs it. With a log, the training's progress
/// goes there in full (info level, as a single process logs it) whichever rank runs it.
[[nodiscard]] int train_job(const SweepJob& job, int real_rank);

/// `imm-train sweep --config PLAN [--summary FILE]`: checks that every job is a command line of
/// its subcommand, then runs the plan over the job's ranks; the root logs every outcome and
/// writes the summary. Exit 0, or support::exit_code::kJobFailed when a training failed.
[[nodiscard]] int run_sweep_command(const std::filesystem::path& plan,
                                    const std::optional<std::filesystem::path>& summary);

}  // namespace imm::pipeline
