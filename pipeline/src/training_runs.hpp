// SPDX-License-Identifier: Apache-2.0
#pragma once
// The options of imm-train's training subcommands and what runs each once they are parsed
// (training_runs.cpp); training_commands.cpp describes the subcommands with them.

#include <cstdint>
#include <filesystem>
#include <optional>

#include "imm/trainer/model_files/freeze.hpp"
#include "imm/trainer/model_files/import_rules.hpp"

namespace imm::pipeline {

/// The --config, --regime, --out and --seed of a training subcommand.
struct TrainCommand {
  std::filesystem::path config, out;
  std::optional<std::filesystem::path> regime;
  std::optional<std::uint64_t> seed;
  bool config_given = false;  // --config was on the command line (not its default)
};

/// `ga`'s options: a training's, and its threads (0: OpenMP's default; at most kMaxThreads) and
/// --resume.
struct GaCommand : TrainCommand {
  static constexpr int kMaxThreads = 1024;
  int threads = 0;
  bool resume = false;
};

/// `tsk`'s options: a training's, and the samples of --data (empty: the regime's own).
struct TskCommand : TrainCommand {
  std::filesystem::path data;
};

[[nodiscard]] int run_ga(const GaCommand& command);
[[nodiscard]] int train_mlp(const TrainCommand& command);
[[nodiscard]] int train_wimm(const TrainCommand& command);
[[nodiscard]] int train_tsk(const TskCommand& command);
[[nodiscard]] int train_fcm(const TrainCommand& command);
[[nodiscard]] int run_freeze(const trainer::FreezeOptions& options);
[[nodiscard]] int run_import_rules(const trainer::ImportRulesOptions& options);
/// `baseline`: the regime's tuned classical filter, of the kind the config's form says.
[[nodiscard]] int run_baseline(const TrainCommand& command);
/// `schedule`: noise schedules learned on the config's tuned CV/CA/CT IMM.
[[nodiscard]] int run_schedule(const TrainCommand& command);

}  // namespace imm::pipeline
