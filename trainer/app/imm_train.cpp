// imm-train: trains (or freezes) models into model files and runs the nightly pipeline.
//
//   imm-train freeze --config configs/track/cv3_imm.toml --out models/cv3_imm.h5
//   imm-train all --config configs/nightly.toml
//
// Progress goes to stderr (spdlog). Exit codes: 0 model written (or every stage passed),
// 1 usage, 2 invalid config or input, 3 a nightly stage failed.

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <iostream>

#include "imm/io/file_error.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/freeze.hpp"
#include "imm/trainer/nightly.hpp"

namespace {

constexpr int kExitBadInput = 2;
constexpr int kExitStageFailed = 3;

int run_freeze(const imm::trainer::FreezeOptions& options) {
  const auto summary = imm::trainer::freeze_plain_imm(options);
  spdlog::info("froze {} ({} modes, {}-state mixing space) into {} in {:.3f} s",
               options.config.string(), summary.modes, summary.state_dimension,
               options.out.string(), summary.wall_seconds);
  return 0;
}

int run_all(const std::filesystem::path& config) {
  const auto plan = imm::trainer::load_nightly_plan(config);
  const auto tools = imm::trainer::executable_folder();
  spdlog::info("nightly plan {}: {} stages, tools from {}", config.string(), plan.stages.size(),
               tools.string());
  imm::trainer::NightlyObserver observer;
  observer.on_start = [](const imm::trainer::NightlyStage& stage, std::size_t index,
                         std::size_t count) {
    std::string command = stage.executable;
    for (const auto& argument : stage.arguments) command += " " + argument;
    spdlog::info("[{}/{}] {} '{}': {}", index + 1, count, stage.kind, stage.name, command);
  };
  observer.on_finish = [](const imm::trainer::StageResult& result) {
    if (result.exit_code == 0) {
      spdlog::info("      {} '{}' done in {:.2f} s", result.stage->kind, result.stage->name,
                   result.wall_seconds);
    } else {
      spdlog::error("      {} '{}' FAILED (exit code {}) after {:.2f} s", result.stage->kind,
                    result.stage->name, result.exit_code, result.wall_seconds);
    }
  };
  const auto results = imm::trainer::run_nightly(
      plan,
      [&](const imm::trainer::NightlyStage& stage) {
        return imm::trainer::run_process(tools / stage.executable, stage.arguments);
      },
      observer);
  double total = 0.0;
  for (const auto& result : results) total += result.wall_seconds;
  const bool failed = results.empty() || results.back().exit_code != 0;
  if (failed) {
    spdlog::error("nightly pipeline stopped after {} of {} stages ({:.1f} s)", results.size(),
                  plan.stages.size(), total);
    return kExitStageFailed;
  }
  spdlog::info("nightly pipeline passed: {} stages in {:.1f} s", results.size(), total);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_st("imm-train"));
  spdlog::set_pattern("%Y-%m-%d %H:%M:%S.%e %^%l%$ %v");
  CLI::App app{"Train immtrain models into model files; run the nightly pipeline."};
  app.require_subcommand(1);

  imm::trainer::FreezeOptions freeze;
  auto* freeze_command =
      app.add_subcommand("freeze", "write a plain-IMM TOML config as a plain_imm model file");
  freeze_command->add_option("--config", freeze.config, "plain-IMM TOML")->required();
  freeze_command->add_option("--out", freeze.out, "model file to write")->required();

  std::filesystem::path nightly_config;
  auto* all_command = app.add_subcommand("all", "run every stage of the nightly plan");
  all_command->add_option("--config", nightly_config, "nightly plan TOML")->required();

  CLI11_PARSE(app, argc, argv);
  try {
    if (*freeze_command) return run_freeze(freeze);
    if (*all_command) return run_all(nightly_config);
  } catch (const imm::support::ConfigError& error) {
    spdlog::error("{}", error.what());
    return kExitBadInput;
  } catch (const imm::io::FileError& error) {
    spdlog::error("{}", error.what());
    return kExitBadInput;
  } catch (const std::exception& error) {
    spdlog::error("{}", error.what());
    return kExitBadInput;
  }
  return 1;
}
