// SPDX-License-Identifier: Apache-2.0
// imm-train: trains (or freezes) models into model files and runs the nightly pipeline.
//
//   imm-train ga --config configs/ga_fuzzy_imm.toml [--regime R] [--out F] [--seed N]
//                [--threads N] [--resume]
//   imm-train import-rules --csv configs/reference/ga_fuzzy_imm_paper_rules.csv
//                          --config configs/ga_fuzzy_imm.toml [--regime R] --out
//                          models/reference/ga_fuzzy_imm_paper.h5
//   imm-train mlp --config configs/mlp_input_estimator.toml [--regime R]
//                 [--out models/mlp_input_estimator.h5] [--seed N]
//   imm-train wimm --config configs/wimm.toml [--regime R] [--out models/wimm.h5] [--seed N]
//   imm-train fcm --config configs/fcm_imm.toml [--regime R] [--out models/fcm_imm.h5] [--seed N]
//   imm-train tsk --config configs/tsk_range_sensor.toml [--regime R]
//                 [--out models/tsk_range_sensor.h5] [--seed N] [--data samples.h5|samples.csv]
//
// Every training config names its regime (configs/regimes/…); --regime trains the same config
// for another regime.
//   imm-train freeze --config configs/track/cv3_imm.toml --out models/cv3_imm.h5
//   imm-train all --config configs/nightly.toml [--force] [--night NAME] [--reports DIR]
//                 [--sweep] [--launcher "mpirun -np 8"]   (candidates trained first, in one sweep)
//   imm-train rollback KIND [REGIME] [--registry models]   (or NAME, a manifest entry's name)
//   imm-train promote FILE --name NAME --reason TEXT [--registry models]
//   imm-train seal FILE
//   imm-train calibrate FILE [--tracks N]   (the covariance calibration, on its training split)
//   [mpirun -np N] imm-train sweep --config sweep.toml [--summary F]   (many trainings; sweep.hpp)
//   mpirun -np N imm-train ga …   (each generation's fitness evaluations spread over the ranks)
//
// Progress goes to stderr (spdlog). Exit codes: 0 model written (or every nightly candidate
// promoted or unchanged), 1 usage, 2 invalid config or input, 3 a nightly stage or a sweep's
// training failed, 4 the
// quality gate failed (no model written), 6 a nightly candidate was held back by the regression
// gate (worse than the shipped model).

#include <omp.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdlib>
#include <sstream>

#include "imm/io/container_file.hpp"
#include "imm/io/file_error.hpp"
#include "imm/pipeline/nightly.hpp"
#include "imm/pipeline/promote.hpp"
#include "imm/pipeline/registry.hpp"
#include "imm/pipeline/training_commands.hpp"
#include "imm/support/cli.hpp"
#include "imm/support/config.hpp"
#include "imm/support/exit_codes.hpp"
#include "imm/support/kind_aliases.hpp"
#include "imm/support/process.hpp"
#include "imm/trainer/model_files/calibration.hpp"
#include "imm/trainer/model_files/envelope.hpp"
#include "imm/trainer/model_files/seal.hpp"
#include "imm/trainer/ranks.hpp"
#include "imm/trainer/temporaries_guard.hpp"

namespace {

namespace exit_code = imm::support::exit_code;

struct NightlyCommand {
  std::filesystem::path config;
  bool force = false;
  bool sweep = false;
  std::string launcher;
  std::string night;
  std::filesystem::path reports = "reports/nightly";
};

int run_all(const NightlyCommand& command) {
  const auto plan = imm::pipeline::load_nightly_plan(command.config);
  imm::pipeline::NightlyOptions options;
  options.tools = imm::support::executable_folder();
  options.force = command.force;
  options.sweep = command.sweep || !command.launcher.empty();
  std::istringstream words(command.launcher);
  for (std::string word; words >> word;) options.launcher.push_back(word);
  options.night = command.night;
  options.reports = command.reports;
  spdlog::info("nightly plan {}: {} stages, tools from {}, registry {}{}", command.config.string(),
               plan.stages.size(), options.tools.string(), plan.registry.string(),
               command.force ? " (--force: nothing cached)" : "");
  options.on_finish = [](const imm::pipeline::StageOutcome& o) {
    const std::string line =
        fmt::format("{} '{}': {} ({}){}{}", o.kind, o.name, o.status,
                    o.cached ? "cached, ran " + o.night : fmt::format("{:.1f} s", o.wall_seconds),
                    o.message.empty() ? "" : " — ", o.message);
    if (o.failed) {
      spdlog::error("{}", line);
    } else if (o.held_back) {
      spdlog::warn("{}", line);
    } else {
      spdlog::info("{}", line);
    }
  };
  const auto result = imm::pipeline::run_nightly(plan, options);
  std::size_t failed = 0, held = 0, cached = 0;
  for (const auto& o : result.stages) failed += o.failed, held += o.held_back, cached += o.cached;
  const std::string summary =
      fmt::format("nightly: {} stages in {:.1f} s, {} failed, {} held back, {} cached; report {}",
                  result.stages.size(), result.wall_seconds, failed, held, cached,
                  (result.report_folder / "index.html").string());
  if (result.exit_code == 0) {
    spdlog::info("{}", summary);
  } else {
    spdlog::error("{} (exit {})", summary, result.exit_code);
  }
  return result.exit_code;
}

int run_rollback(const std::string& kind, const std::string& regime,
                 const std::filesystem::path& registry_folder) {
  imm::pipeline::Registry registry(registry_folder);
  // A command killed before left the manifest's state or the one before it: make the files the
  // manifest's first, so the rollback starts from what is recorded.
  for (const auto& restored : registry.repair())
    spdlog::info("restored {} from the archive", restored);
  // An entry's own name (a nightly stage's: "ga_fuzzy_imm_agile_air", a tracker's "agile_air")
  // names exactly one model.
  auto found = registry.find(kind, regime);
  if (const auto* named = registry.find(kind); named != nullptr && regime.empty()) found = {named};
  if (found.empty()) {
    spdlog::error("rollback: no shipped {} model for regime {} in {}",
                  imm::pipeline::quoted_for_message(kind, 64),
                  imm::pipeline::quoted_for_message(regime, 64), registry.manifest_path().string());
    return exit_code::kBadInput;
  }
  if (found.size() > 1) {
    std::string names;
    for (const auto* e : found) names += " " + e->name;
    spdlog::error(
        "rollback: {} models of kind {} for regime {}:{}; name one: imm-train rollback "
        "NAME",
        found.size(), imm::pipeline::quoted_for_message(kind, 64),
        imm::pipeline::quoted_for_message(regime, 64), names);
    return exit_code::kBadInput;
  }
  const std::string name = found.front()->name;
  const std::string replaced = found.front()->sha256;
  const auto restored = registry.rollback(name);
  spdlog::info("rolled back {}: {} ({}) replaces {}", name, restored.file,
               restored.sha256.substr(0, 12), replaced.substr(0, 12));
  return 0;
}

}  // namespace

int run(int argc, char** argv) {
  const imm::trainer::Ranks& ranks = imm::trainer::Ranks::world();
  spdlog::set_default_logger(spdlog::stderr_color_st("imm-train"));
  imm::pipeline::log_as(ranks.rank());
  CLI::App app{"Train immtrain models into model files; run the nightly pipeline."};
  imm::support::standard_options(app, "imm-train");
  app.require_subcommand(1);

  const imm::pipeline::TrainingCommands training(app);

  NightlyCommand nightly;
  auto* all_command = app.add_subcommand(
      "all", "the nightly: train candidates, evaluate, promote what passes, write the report");
  all_command->add_option("--config", nightly.config, "nightly plan TOML")->required();
  all_command->add_flag(
      "--force", nightly.force,
      "rerun every stage (ignore the stage cache) and let a rolled-back model be promoted again");
  all_command->add_option("--night", nightly.night, "report folder name (default: UTC date)");
  all_command->add_option("--reports", nightly.reports, "where the nightly reports go");
  all_command->add_flag("--sweep", nightly.sweep,
                        "train every candidate that is not cached first, in one 'imm-train sweep'");
  all_command->add_option("--launcher", nightly.launcher,
                          "start that sweep with this command, words split at spaces ('mpirun -np "
                          "8', 'srun'); implies --sweep");

  std::filesystem::path sweep_plan;
  std::optional<std::filesystem::path> sweep_summary;
  auto* sweep_command = app.add_subcommand(
      "sweep",
      "train many models (kind x regime x seed); under mpirun the ranks take them as they free up");
  sweep_command->add_option("--config", sweep_plan, "sweep plan TOML ([[jobs]])")->required();
  sweep_command->add_option("--summary", sweep_summary,
                            "write every job's outcome there (JSON: exit code, rank, seconds)");

  std::filesystem::path seal_path;
  auto* seal_command = app.add_subcommand(
      "seal",
      "re-seal a model file edited with other tools (h5py), after checking that it still reads");
  seal_command->add_option("file", seal_path, "model file")->required();

  std::filesystem::path calibrate_path;
  imm::trainer::CalibrationSettings calibration_settings;
  auto* calibrate_command = app.add_subcommand(
      "calibrate",
      "fit a model file's covariance calibration on its regime's training split and store it "
      "(the envelope refitted to the calibrated NIS)");
  calibrate_command->add_option("file", calibrate_path, "model file")->required();
  calibrate_command->add_option("--tracks", calibration_settings.tracks, "training tracks run")
      ->check(imm::support::at_least(1));

  imm::pipeline::PromoteOptions promote_options;
  auto* promote_command = app.add_subcommand(
      "promote",
      "ship a model file past the nightly's gates, deliberately, with the reason recorded");
  promote_command->add_option("file", promote_options.file, "model file")->required();
  promote_command->add_option("--name", promote_options.name, "registry entry (nightly stage name)")
      ->required();
  promote_command->add_option("--reason", promote_options.reason, "why, in a sentence")->required();
  promote_command->add_option("--registry", promote_options.registry, "registry folder");

  std::string rollback_kind, rollback_regime;
  std::filesystem::path rollback_registry = "models";
  auto* rollback_command = app.add_subcommand("rollback",
                                              "restore the model a promotion replaced: imm-train "
                                              "rollback KIND [REGIME], or NAME (a manifest entry)");
  rollback_command->add_option("kind", rollback_kind, "model kind or nightly command (ga, …)")
      ->required();
  rollback_command->add_option("regime", rollback_regime,
                               "regime name (omitted: a model trained for no regime)");
  rollback_command->add_option("--registry", rollback_registry, "registry folder (models)");

  imm::support::alias_model_kinds(app);
  if (const auto exit = imm::support::parse(app, argc, argv)) return *exit;
  if (ranks.size() > 1) {
    const imm::pipeline::TrainingKind* chosen = training.chosen();
    if (!(chosen != nullptr && chosen->distributed) && !*sweep_command) {
      std::string spreading;
      for (const auto& kind : imm::pipeline::training_kinds()) {
        if (kind.distributed) spreading += (spreading.empty() ? "'" : ", '") + kind.command + "'";
      }
      spdlog::error(
          "imm-train {} runs as one process: under mpirun only {} spreads its work over the "
          "ranks (and 'sweep' hands out whole trainings)",
          app.get_subcommands().front()->get_name(), spreading);
      return 1;
    }
    // Each rank's OpenMP threads: OMP_NUM_THREADS when set (a Slurm script's cpus-per-task), the
    // cores the launcher bound the rank to, or else its part of the machine's cores.
    if (std::getenv("OMP_NUM_THREADS") == nullptr) {
      const int bound = omp_get_num_procs();
      const int machine = static_cast<int>(::sysconf(_SC_NPROCESSORS_ONLN));
      omp_set_num_threads(bound < machine ? bound : std::max(1, machine / ranks.local_size()));
    }
  }
  // A training killed with SIGKILL while writing leaves a hidden temporary beside its output: a
  // guard process removes it (see temporaries_guard.hpp).
  if (const auto out = training.chosen_out()) {
    imm::trainer::guard_temporaries({out->parent_path().empty() ? "." : out->parent_path()});
  }
  try {
    if (training.chosen_out()) return training.run();
    if (*all_command) return run_all(nightly);
    if (*sweep_command) return imm::pipeline::run_sweep_command(sweep_plan, sweep_summary);
    if (*rollback_command) return run_rollback(rollback_kind, rollback_regime, rollback_registry);
    if (*promote_command) {
      const auto entry = imm::pipeline::promote_by_hand(promote_options);
      spdlog::info("promoted {} as {} ({}, sha256 {}): {}", promote_options.file.string(),
                   entry.name, entry.file, entry.sha256.substr(0, 12), entry.promotion_reason);
      return 0;
    }
    if (*calibrate_command) {
      const auto fit = imm::trainer::fit_calibration(calibrate_path, calibration_settings);
      spdlog::info("{}", imm::trainer::describe(fit));
      if (!fit.fitted) return exit_code::kBadInput;
      imm::trainer::store_calibration(calibrate_path, fit.calibration);
      spdlog::info(
          "{}", imm::trainer::describe(imm::trainer::calibrate_and_store_envelope(calibrate_path)));
      return 0;
    }
    if (*seal_command) {
      const auto sealed = imm::trainer::seal_model_file(seal_path);
      if (sealed.before != "intact") spdlog::warn("before sealing: {}", sealed.before);
      spdlog::info("sealed {} ({}, sha256 {})", seal_path.string(), sealed.kind,
                   sealed.sha256.substr(0, 16));
      return 0;
    }
  } catch (const imm::support::ConfigError& error) {
    spdlog::error("{}", imm::support::one_line(error.what()));
    return exit_code::kBadInput;
  } catch (const imm::io::FileError& error) {
    spdlog::error("{}", imm::support::one_line(error.what()));
    return exit_code::kBadInput;
  } catch (const std::exception& error) {
    spdlog::error("{}", imm::support::one_line(error.what()));
    return exit_code::kBadInput;
  } catch (...) {
    spdlog::error("unexpected error");
    return exit_code::kBadInput;
  }
  return 1;
}

int main(int argc, char** argv) {
  imm::io::skip_hdf5_shutdown_at_exit();  // before any HDF5 call (container_file.hpp)
  imm::support::keep_freed_memory();      // buffers rebuilt every generation: no page faults
  const imm::trainer::Ranks::Session session(argc, argv);
  const int code = run(argc, argv);
  // A rank that fails (a file it cannot write, an error only it saw) must not leave the others
  // waiting for it in the next exchange: the job ends on every rank. A quality gate's verdict is
  // the same on every rank, and a sweep's failed trainings are in its summary: both end the job
  // normally.
  if (code != 0 && code != exit_code::kTrainingGateFailed && code != exit_code::kJobFailed) {
    imm::trainer::Ranks::world().abort_job(code);
  }
  return code;
}
