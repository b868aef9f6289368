// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The job language of imm-train: the subcommands that write one model file (ga, mlp, wimm, fcm,
/// tsk, freeze, import-rules), their command lines and how each runs. imm-train parses its own
/// command line with them, and a sweep (sweep.hpp) parses each job's arguments with the same
/// parser, so a job runs exactly as its subcommand would.

#include <CLI/CLI.hpp>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <utility>
#include <vector>

#include "imm/pipeline/sweep.hpp"
#include "imm/trainer/model_files/freeze.hpp"
#include "imm/trainer/model_files/import_rules.hpp"

namespace imm::pipeline {

struct GaCommand {
  std::filesystem::path config = "configs/ga_fuzzy_imm.toml";
  std::filesystem::path out = "models/ga_fuzzy_imm.h5";
  std::optional<std::filesystem::path> regime;
  std::optional<std::uint64_t> seed;
  int threads = 0;
  bool resume = false;
};

/// The --config, --regime, --out and --seed of a training subcommand.
struct TrainCommand {
  std::filesystem::path config, out;
  std::optional<std::filesystem::path> regime;
  std::optional<std::uint64_t> seed;
};

/// The log of rank `rank`: the root reports progress; the other ranks only what goes wrong on
/// them, their lines marked with their rank.
void log_as(int rank);

/// The subcommands that write one model file (sweep_subcommands()), added to `app`: on the
/// command line, and as a sweep's jobs, which run exactly them.
class TrainingCommands {
 public:
  explicit TrainingCommands(CLI::App& app);
  TrainingCommands(const TrainingCommands&) = delete;
  TrainingCommands& operator=(const TrainingCommands&) = delete;

  /// The model file of the subcommand the command line chose, if it chose one of these.
  [[nodiscard]] std::optional<std::filesystem::path> chosen_out() const;

  /// Runs the chosen subcommand, then calibrates the written model's envelope test on its regime
  /// (imm/trainer/model_files/envelope.hpp); its exit code (support/exit_codes.hpp).
  [[nodiscard]] int run() const;

  [[nodiscard]] const CLI::App* ga() const { return ga_; }

 private:
  [[nodiscard]] int dispatch() const;
  [[nodiscard]] std::vector<std::pair<const CLI::App*, std::filesystem::path>> outputs() const;

  GaCommand ga_command_;
  trainer::FreezeOptions freeze_options_;
  trainer::ImportRulesOptions import_options_;
  TrainCommand mlp_command_{
      "configs/mlp_input_estimator.toml", "models/mlp_input_estimator.h5", {}, {}};
  TrainCommand wimm_command_{"configs/wimm.toml", "models/wimm.h5", {}, {}};
  TrainCommand fcm_command_{"configs/fcm_imm.toml", "models/fcm_imm.h5", {}, {}};
  TrainCommand baseline_command_{"configs/ga_fuzzy_imm_tuned.toml", {}, {}, {}};
  TrainCommand tsk_command_{"configs/tsk_range_sensor.toml", "models/tsk_range_sensor.h5", {}, {}};
  TrainCommand schedule_command_{"configs/scheduled_ct_imm.toml", {}, {}, {}};
  std::filesystem::path tsk_data_;
  CLI::App *freeze_ = nullptr, *ga_ = nullptr, *import_ = nullptr, *mlp_ = nullptr,
           *wimm_ = nullptr, *fcm_ = nullptr, *tsk_ = nullptr, *baseline_ = nullptr,
           *schedule_ = nullptr;
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
