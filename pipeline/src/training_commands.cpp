// SPDX-License-Identifier: Apache-2.0
#include "imm/pipeline/training_commands.hpp"

#include <spdlog/spdlog.h>

#include <memory>
#include <stdexcept>

#include "imm/model_kinds.hpp"
#include "imm/support/cli.hpp"
#include "imm/trainer/model_files/write_model.hpp"
#include "training_runs.hpp"

namespace imm::pipeline {
namespace {

// What runs `run` with the options parsed into `options`, and their --out.
template <class Options>
TrainingRun runner(std::shared_ptr<Options> options, int (*run)(const Options&)) {
  return {[options, run] { return run(*options); }, [options] { return options->out; }};
}

// A training's options (--config, --regime, --out, --seed) on `command`, their defaults
// `defaults`; `run` trains with them.
template <class Command = TrainCommand>
TrainingRun training(CLI::App& command, Command defaults, int (*run)(const Command&),
                     bool out_required = false,
                     const std::function<void(CLI::App&, Command&)>& more = {}) {
  auto options = std::make_shared<Command>(std::move(defaults));
  command.add_option("--config", options->config, "training config TOML")
      ->each([options](const std::string&) { options->config_given = true; });
  command.add_option("--regime", options->regime,
                     "regime TOML to train for (replaces the config's)");
  auto* out = command.add_option("--out", options->out, "model file to write");
  if (out_required) out->required();
  command.add_option("--seed", options->seed, "override the config's seed")
      ->check(imm::support::seed());
  if (more) more(command, *options);
  return runner(options, run);
}

TrainCommand defaults(const char* config, const char* out = "") { return {config, out, {}, {}}; }

std::vector<TrainingKind> make_training_kinds() {
  std::vector<TrainingKind> kinds;
  kinds.push_back({
      .command = "freeze",
      .model_kind = "plain_imm",
      .about = "write a plain-IMM TOML config as a plain_imm model file",
      .training_options = false,
      .add =
          [](CLI::App& command) {
            auto options = std::make_shared<trainer::FreezeOptions>();
            command.add_option("--config", options->config, "plain-IMM TOML")->required();
            command.add_option("--out", options->out, "model file to write")->required();
            return runner(options, run_freeze);
          },
  });
  kinds.push_back({
      .command = "ga",
      .model_kind = "ga_fuzzy_imm",
      .about = "learn the fuzzy rule tables of the GA-fuzzy IMM (seed 000)",
      .distributed = true,
      .add =
          [](CLI::App& command) {
            GaCommand ga;
            ga.config = "configs/ga_fuzzy_imm.toml";
            ga.out = "models/ga_fuzzy_imm.h5";
            return training<GaCommand>(
                command, ga, run_ga, false, [](CLI::App& c, GaCommand& options) {
                  c.get_option("--config")->description("GA config TOML");
                  // Bounded: OpenMP starts every thread asked for (with a million the first
                  // generation had not begun after a minute); the results do not depend on it.
                  c.add_option("--threads", options.threads, "OpenMP threads (default: all cores)")
                      ->check(support::within(1, GaCommand::kMaxThreads, ""));
                  c.add_flag("--resume", options.resume,
                             "continue from the checkpoint beside --out");
                });
          },
  });
  kinds.push_back({
      .command = "import-rules",
      .model_kind = "ga_fuzzy_imm",
      .about = "write published fuzzy rule tables (CSV) as a ga_fuzzy_imm model file",
      .training_options = false,
      .add =
          [](CLI::App& command) {
            auto options = std::make_shared<trainer::ImportRulesOptions>();
            command.add_option("--csv", options->csv, "rules: level,c1,sigma1,c2,sigma2,w")
                ->required();
            command.add_option("--config", options->config, "GA config whose [filter] applies")
                ->required();
            command.add_option("--regime", options->regime, "regime TOML (replaces the config's)");
            command.add_option("--out", options->out, "model file to write")->required();
            return runner(options, run_import_rules);
          },
  });
  kinds.push_back({
      .command = "mlp",
      .model_kind = "mlp_input_estimator",
      .about = "train the neural input estimator (seed 001) by back-propagation",
      .add =
          [](CLI::App& command) {
            return training(
                command,
                defaults("configs/mlp_input_estimator.toml", "models/mlp_input_estimator.h5"),
                train_mlp);
          },
  });
  kinds.push_back({
      .command = "wimm",
      .model_kind = "wimm",
      .about = "tune the weighted IMM's fusion threshold and weight (seed 004) on the regime's "
               "training split",
      .add =
          [](CLI::App& command) {
            return training(command, defaults("configs/wimm.toml", "models/wimm.h5"), train_wimm);
          },
  });
  kinds.push_back({
      .command = "fcm",
      .model_kind = "fcm_imm",
      .about = "fit the FCM-IMM's parameters (seed 003) on the regime's training split",
      .add =
          [](CLI::App& command) {
            return training(command, defaults("configs/fcm_imm.toml", "models/fcm_imm.h5"),
                            train_fcm);
          },
  });
  kinds.push_back({
      .command = "baseline",
      .about =
          "write the regime's tuned classical filter, tuned on the training split: with a GA "
          "config the constant-q IMM per axis (its levels and stay; the config's level count and "
          "budget), with a wIMM config (a polar regime) the normal IMM (q1 and P(CV->CV), fusion "
          "off), with a [classical] config the CV/CA/CT IMM (modes, intensities, stay); without "
          "--config, configs/wimm_tuned.toml for a polar --regime and the GA config otherwise",
      .add =
          [](CLI::App& command) {
            return training(command, defaults("configs/ga_fuzzy_imm_tuned.toml"), run_baseline,
                            true);
          },
  });
  kinds.push_back({
      .command = "schedule",
      .model_kind = "plain_imm",
      .about = "learn fuzzy noise schedules (seed 000's idea) on the regime's tuned CV/CA/CT IMM: "
               "every mode's Q scaled by a rule table of its normalized innovation, kept when it "
               "improves the validation split",
      .add =
          [](CLI::App& command) {
            return training(command, defaults("configs/scheduled_ct_imm.toml"), run_schedule, true);
          },
  });
  kinds.push_back({
      .command = "tsk",
      .model_kind = "tsk_sensor",
      .about = "fit the probabilistic TSK model of a range sensor (seed 002): FCRM, then Ceres",
      .add =
          [](CLI::App& command) {
            TskCommand tsk;
            tsk.config = "configs/tsk_range_sensor.toml";
            tsk.out = "models/tsk_range_sensor.h5";
            return training<TskCommand>(
                command, tsk, train_tsk, false, [](CLI::App& c, TskCommand& options) {
                  c.add_option("--data", options.data,
                               "fit these samples (a range-sensor data set .h5 or a CSV "
                               "xi,eta,z1,z2); they must be the sensor samples the regime names");
                });
          },
  });
  return kinds;
}

}  // namespace

const std::vector<TrainingKind>& training_kinds() {
  static const std::vector<TrainingKind> kinds = make_training_kinds();
  return kinds;
}

const TrainingKind* find_training_kind(std::string_view name) {
  for (const TrainingKind& kind : training_kinds()) {
    if (!kind.training_options) continue;
    const ModelKind* named = find_model_kind(kind.command);
    if (kind.command == name || (named != nullptr && named->answers_to(name))) return &kind;
  }
  return nullptr;
}

void log_as(int rank) {
  if (rank == 0) {
    spdlog::set_pattern("%Y-%m-%d %H:%M:%S.%e %^%l%$ %v");
    spdlog::set_level(spdlog::level::info);
  } else {
    spdlog::set_pattern(fmt::format("%Y-%m-%d %H:%M:%S.%e [rank {}] %^%l%$ %v", rank));
    spdlog::set_level(spdlog::level::warn);
  }
}

TrainingCommands::TrainingCommands(CLI::App& app) {
  for (const TrainingKind& kind : training_kinds()) {
    CLI::App* command = app.add_subcommand(kind.command, kind.about);
    added_.push_back({&kind, command, kind.add(*command)});
  }
}

const TrainingCommands::Added* TrainingCommands::chosen_added() const {
  for (const Added& added : added_) {
    if (*added.command) return &added;
  }
  return nullptr;
}

const TrainingKind* TrainingCommands::chosen() const {
  const Added* added = chosen_added();
  return added != nullptr ? added->kind : nullptr;
}

std::optional<std::filesystem::path> TrainingCommands::chosen_out() const {
  const Added* added = chosen_added();
  if (added == nullptr) return std::nullopt;
  return added->run.out();
}

int TrainingCommands::run() const {
  const Added* added = chosen_added();
  if (added == nullptr) throw std::logic_error("no training subcommand was chosen");
  // Every model file a training command writes appears under its name calibrated (its covariance
  // and its envelope, fitted on the written model before the rename: write_model.hpp).
  const trainer::ModelFinishScope finish(trainer::calibrate_model_file);
  return added->run.run();
}

}  // namespace imm::pipeline
