#pragma once
/// The nightly pipeline of `imm-train all --config configs/nightly.toml`: data sets, then models,
/// then tracking runs, then evaluations, each as its own process (a crash or a failed quality gate
/// in one stage is an exit code, never a half-finished pipeline that looks green), stopping at the
/// first failure.
///
/// configs/nightly.toml:
///   [[data]]         name, command (tracks | sensor), regime, out, [split], [csv], [count], [seed]
///   [[models]]       name, command (an imm-train subcommand), config, out, [regime], [seed],
///                    [arguments]
///   [[tracks]]       filter, measurements, out
///   [[evaluations]]  experiment, models, out, [model], [regime], [runs], [seed], [arguments]

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace imm::trainer {

struct NightlyStage {
  std::string kind;        ///< "data", "model", "track", "evaluation"
  std::string name;        ///< for the log
  std::string executable;  ///< imm-data, imm-train, imm-track, imm-eval
  std::vector<std::string> arguments;
  std::vector<std::filesystem::path> output_folders;  ///< created before the stage runs
};

struct NightlyPlan {
  std::vector<NightlyStage> stages;
};

/// Reads and checks configs/nightly.toml (unknown keys and wrong types are ConfigErrors).
[[nodiscard]] NightlyPlan load_nightly_plan(const std::filesystem::path& path);

struct StageResult {
  const NightlyStage* stage = nullptr;
  int exit_code = 0;
  double wall_seconds = 0.0;
};

struct NightlyObserver {
  std::function<void(const NightlyStage&, std::size_t index, std::size_t count)> on_start;
  std::function<void(const StageResult&)> on_finish;
};

/// Runs stages in order with `run` (returns an exit code) until one fails. Returns the results of
/// the stages that ran.
std::vector<StageResult> run_nightly(const NightlyPlan& plan,
                                     const std::function<int(const NightlyStage&)>& run,
                                     const NightlyObserver& observer = {});

/// Runs `executable` (a path, or a bare name looked up in PATH) with `arguments`, inheriting
/// stdout/stderr; returns its exit code, or 128 + signal when it was killed.
int run_process(const std::filesystem::path& executable, const std::vector<std::string>& arguments);

/// The folder of the running executable (where the sibling tools are).
[[nodiscard]] std::filesystem::path executable_folder();

}  // namespace imm::trainer
