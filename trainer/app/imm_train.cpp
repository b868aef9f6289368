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
//   imm-train rollback KIND [REGIME] [--registry models]
//   imm-train promote FILE --name NAME --reason TEXT [--registry models]
//   imm-train seal FILE
//   [mpirun -np N] imm-train sweep --config sweep.toml [--summary F]   (many trainings; sweep.hpp)
//   mpirun -np N imm-train ga …   (each generation's fitness evaluations spread over the ranks)
//
// Progress goes to stderr (spdlog). Exit codes: 0 model written (or every nightly candidate
// promoted or unchanged), 1 usage, 2 invalid config or input, 3 a nightly stage or a sweep's
// training failed, 4 the
// quality gate failed (no model written), 6 a nightly candidate was held back by the regression
// gate (worse than the shipped model).

#include <omp.h>
#include <spdlog/fmt/ranges.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <set>
#include <sstream>

#include "imm/datasets/random.hpp"
#include "imm/io/file_error.hpp"
#include "imm/support/cli.hpp"
#include "imm/support/config.hpp"
#include "imm/support/exit_codes.hpp"
#include "imm/support/process.hpp"
#include "imm/trainer/fcm/fcm_trainer.hpp"
#include "imm/trainer/freeze.hpp"
#include "imm/trainer/ga/ga_trainer.hpp"
#include "imm/trainer/import_rules.hpp"
#include "imm/trainer/mlp/mlp_trainer.hpp"
#include "imm/trainer/nightly.hpp"
#include "imm/trainer/promote.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/ranks.hpp"
#include "imm/trainer/registry.hpp"
#include "imm/trainer/seal.hpp"
#include "imm/trainer/sweep.hpp"
#include "imm/trainer/temporaries_guard.hpp"
#include "imm/trainer/tsk/tsk_trainer.hpp"
#include "imm/trainer/wimm/wimm_trainer.hpp"

namespace {

namespace exit_code = imm::support::exit_code;

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

CLI::App* add_train_command(CLI::App& app, const std::string& name, const std::string& about,
                            TrainCommand& command) {
  auto* sub = app.add_subcommand(name, about);
  sub->add_option("--config", command.config, "training config TOML");
  sub->add_option("--regime", command.regime, "regime TOML to train for (replaces the config's)");
  sub->add_option("--out", command.out, "model file to write");
  sub->add_option("--seed", command.seed, "override the config's seed");
  return sub;
}

/// The log of rank `rank`: the root reports progress; the other ranks only what goes wrong on
/// them, their lines marked with their rank.
void log_as(int rank) {
  if (rank == 0) {
    spdlog::set_pattern("%Y-%m-%d %H:%M:%S.%e %^%l%$ %v");
    spdlog::set_level(spdlog::level::info);
  } else {
    spdlog::set_pattern(fmt::format("%Y-%m-%d %H:%M:%S.%e [rank {}] %^%l%$ %v", rank));
    spdlog::set_level(spdlog::level::warn);
  }
}

int run_ga(const GaCommand& command) {
  namespace ga = imm::trainer::ga;
  ga::GaTrainingConfig config = ga::load_ga_config(command.config, command.regime);
  if (command.seed) config.seed = *command.seed;
  if (command.threads > 0) omp_set_num_threads(command.threads);
  const std::size_t levels = config.levels.size();
  const int generations = config.ga.generations;
  spdlog::info("ga: regime {}, levels [{}] {}, population {}, {} generations, seed {}, {} threads",
               config.regime.name, fmt::join(config.levels, ", "),
               imm::datasets::to_string(config.regime.units) == "km" ? "km/s²" : "m/s²",
               config.ga.population, generations, config.seed, omp_get_max_threads());

  ga::GaObserver observer;
  observer.on_resume = [&](std::size_t level, int generation) {
    spdlog::info("resuming level {} at generation {} from {}", ga::level_name(config.levels[level]),
                 generation, ga::checkpoint_path(command.out).string());
  };
  observer.on_generation = [&](std::size_t level, const ga::GenerationLog& log, double seconds) {
    if (log.generation % 10 != 0 && log.generation != generations) return;
    const double per_generation = log.generation > 0 ? seconds / log.generation : 0.0;
    const double eta = per_generation * ((generations - log.generation) +
                                         static_cast<double>(levels - level - 1) * generations);
    spdlog::info(
        "level {} [{}/{}] generation {:3}/{}: best fitness {:.5f} (error {:.4f}, {} rules), "
        "mean {:.5f}, ETA {:.0f} s",
        ga::level_name(config.levels[level]), level + 1, levels, log.generation, generations,
        log.best_fitness, log.best_error, log.best_rules, log.mean_fitness, eta);
  };
  observer.on_level_done = [&](std::size_t, const ga::LevelResult& r) {
    const std::string memetic =
        r.memetic_evaluations > 0
            ? fmt::format("fitness {:.5f} -> {:.5f} after memetic ({} evaluations)",
                          r.before_memetic.fitness, r.training.fitness, r.memetic_evaluations)
            : fmt::format("fitness {:.5f}", r.training.fitness);
    spdlog::info(
        "level {} done in {:.1f} s: {}, {} rules, training error {:.4f}, validation "
        "error {:.4f}",
        ga::level_name(r.maneuver_level), r.wall_seconds, memetic, r.training.rules,
        r.training.error, r.validation.error);
  };
  const ga::GaTrainingResult result = ga::train_ga(config, {command.out, command.resume}, observer);
  if (!result.gate_passed) {
    spdlog::error("quality gate failed: {}; {} not written", result.gate_message,
                  command.out.string());
    return exit_code::kTrainingGateFailed;
  }
  spdlog::info("wrote {} and {} ({:.1f} s)", command.out.string(),
               imm::trainer::metrics_path(command.out).string(), result.wall_seconds);
  const imm::trainer::Ranks& ranks = imm::trainer::Ranks::world();
  if (ranks.distributed()) {
    spdlog::info(
        "{} ranks: the root sent {} bytes in {} messages to the others, {:.3f} s in "
        "exchanges (waiting for the slowest rank included)",
        ranks.size(), ranks.bytes_sent(), ranks.messages_sent(), ranks.exchange_seconds());
  }
  return 0;
}

int train_mlp(const TrainCommand& command) {
  auto config = imm::trainer::mlp::load_mlp_config(command.config, command.regime);
  if (command.seed) {
    config.seed = *command.seed;
    config.training.seed = imm::datasets::derive_seed(config.seed, 3);
  }
  int epochs = 0;
  for (const auto& phase : config.training.phases) epochs += phase.epochs;
  spdlog::info("mlp: regime {}, {} training and {} validation tracks, {} epochs, seed {}",
               config.regime.name, config.regime.splits.training, config.regime.splits.validation,
               epochs, config.seed);
  const auto result = imm::trainer::mlp::train_mlp(config, command.out);
  const std::size_t step = std::max<std::size_t>(1, result.loss.size() / 8);
  for (std::size_t i = 0; i < result.loss.size(); i += step) {
    const auto& p = result.loss[i];
    spdlog::info("epoch {:5}/{}: training MSE {:.4f}, validation MSE {:.4f} (m/s²)²", p.epoch,
                 epochs, p.training, p.validation);
  }
  spdlog::info(
      "trained in {:.2f} s (back-propagation {:.2f} s): RMSE {:.3f} / {:.3f} m/s² "
      "(training / validation); no-maneuver output {:.3f} m/s² before, {:.3f} after "
      "removing the trained bias",
      result.wall_seconds, result.training_seconds, result.training_rmse, result.validation_rmse,
      result.bias_before, result.bias_after);
  if (!result.gate_passed) {
    spdlog::error("quality gate failed: validation RMSE {:.3f} m/s² exceeds {:.3f}; {} not written",
                  result.validation_rmse, config.max_validation_rmse, command.out.string());
    return exit_code::kTrainingGateFailed;
  }
  spdlog::info("wrote {}", command.out.string());
  return 0;
}

int train_wimm(const TrainCommand& command) {
  auto config = imm::trainer::wimm::load_wimm_config(command.config, command.regime);
  if (command.seed) config.seed = *command.seed;
  spdlog::info("wimm: tuning threshold and alpha on regime {}: {} training tracks of {} scans",
               config.regime.name, config.regime.splits.training, config.regime.scans);
  const auto result = imm::trainer::wimm::train_wimm(config, command.out);
  spdlog::info(
      "threshold {:.4f}, alpha {:.4f}: settled azimuth RMSE x{:.4f}, position RMSE "
      "x{:.4f} of the normal IMM on the training scenarios ({} evaluations, {:.1f} s); "
      "wrote {}",
      result.tuned.spec.threshold, result.tuned.spec.alpha, result.tuned.azimuth_ratio,
      result.tuned.position_ratio, result.tuned.evaluations, result.wall_seconds,
      command.out.string());
  return 0;
}

int train_tsk(const TrainCommand& command, const std::filesystem::path& tsk_data) {
  auto config = imm::trainer::tsk::load_tsk_config(command.config, command.regime);
  if (command.seed) config.seed = *command.seed;
  const auto samples = tsk_data.empty() ? imm::trainer::tsk::calibration_samples(config)
                                        : imm::trainer::tsk::load_sensor_samples(tsk_data, config);
  spdlog::info(
      "tsk: {} samples from {} ({:.0f} % held out), {} rules per output, t-norm {}, seed {}",
      samples.data.positions.rows(), samples.source, 100.0 * config.validation_fraction,
      config.fcrm.clusters, imm::to_string(config.t_norm), config.seed);
  const auto result = imm::trainer::tsk::train_tsk(config, samples, command.out);
  spdlog::info("fitted in {:.2f} s", result.wall_seconds);
  if (!result.gate_passed) {
    spdlog::error("quality gate failed: a validation RMSE exceeds {:.3f} m; {} not written",
                  config.max_validation_rmse, command.out.string());
    return exit_code::kTrainingGateFailed;
  }
  spdlog::info("wrote {}", command.out.string());
  return 0;
}

int train_fcm(const TrainCommand& command) {
  auto config = imm::trainer::fcm::load_fcm_config(command.config, command.regime);
  if (command.seed) config.seed = *command.seed;
  spdlog::info(
      "fcm: regime {}: fitting on {} training tracks ({} held out, {} scans, seed {}), "
      "windows {}",
      config.regime.name, config.regime.splits.training, config.regime.splits.validation,
      config.regime.scans, config.seed, fmt::join(config.tuning.windows, ", "));
  const auto result = imm::trainer::fcm::train_fcm(config, command.out);
  const auto& s = result.spec;
  spdlog::info(
      "fitted: window {}, lambda {:.3f}, m {:.2f}, kappa {:.2f}, stay {:.4f}, q = {:.4g} "
      "(m/s^2)^2; J = {:.4f} training, {:.4f} validation (lambda = 0 IMM {:.4f}, KF {:.4f}); "
      "{} evaluations, {:.1f} s",
      s.window, s.compensation_gain, s.clustering.fuzzifier, s.separation, s.transition(0, 0),
      fmt::join(s.process_noise, ", "), result.training.objective, result.validation.objective,
      result.imm_validation.objective, result.kf_validation.objective, result.evaluations,
      result.wall_seconds);
  if (!result.gate_passed) {
    spdlog::error(
        "quality gate failed: validation J {:.4f} exceeds {:.3f} x the tuned KF's "
        "{:.4f}; {} not written",
        result.validation.objective, config.max_validation_ratio, result.kf_validation.objective,
        command.out.string());
    return exit_code::kTrainingGateFailed;
  }
  spdlog::info("wrote {}", command.out.string());
  return 0;
}

int run_freeze(const imm::trainer::FreezeOptions& options) {
  const auto summary = imm::trainer::freeze_plain_imm(options);
  spdlog::info("froze {} ({} modes, {}-state mixing space) into {} in {:.3f} s",
               options.config.string(), summary.modes, summary.state_dimension,
               options.out.string(), summary.wall_seconds);
  return 0;
}

int run_import_rules(const imm::trainer::ImportRulesOptions& options) {
  const auto spec = imm::trainer::import_rules(options);
  std::size_t rules = 0;
  for (const auto& level : spec.levels) rules += level.table.size();
  spdlog::info("imported {} levels ({} rules) from {} into {}", spec.levels.size(), rules,
               options.csv.string(), options.out.string());
  return 0;
}

/// The subcommands that write one model file (imm::trainer::sweep_subcommands()): on the command
/// line, and as a sweep's jobs, which run exactly them.
class TrainingCommands {
 public:
  explicit TrainingCommands(CLI::App& app) {
    freeze_ =
        app.add_subcommand("freeze", "write a plain-IMM TOML config as a plain_imm model file");
    freeze_->add_option("--config", freeze_options_.config, "plain-IMM TOML")->required();
    freeze_->add_option("--out", freeze_options_.out, "model file to write")->required();

    ga_ = app.add_subcommand("ga", "learn the fuzzy rule tables of the GA-fuzzy IMM (seed 000)");
    ga_->add_option("--config", ga_command_.config, "GA config TOML");
    ga_->add_option("--regime", ga_command_.regime,
                    "regime TOML to train for (replaces the config's)");
    ga_->add_option("--out", ga_command_.out, "model file to write");
    ga_->add_option("--seed", ga_command_.seed, "override the config's seed");
    ga_->add_option("--threads", ga_command_.threads, "OpenMP threads (default: all cores)")
        ->check(imm::support::at_least(1));
    ga_->add_flag("--resume", ga_command_.resume, "continue from the checkpoint beside --out");

    import_ = app.add_subcommand(
        "import-rules", "write published fuzzy rule tables (CSV) as a ga_fuzzy_imm model file");
    import_->add_option("--csv", import_options_.csv, "rules: level,c1,sigma1,c2,sigma2,w")
        ->required();
    import_->add_option("--config", import_options_.config, "GA config whose [filter] applies")
        ->required();
    import_->add_option("--regime", import_options_.regime, "regime TOML (replaces the config's)");
    import_->add_option("--out", import_options_.out, "model file to write")->required();

    mlp_ = add_train_command(app, "mlp",
                             "train the neural input estimator (seed 001) by back-propagation",
                             mlp_command_);
    wimm_ = add_train_command(app, "wimm",
                              "tune the weighted IMM's fusion threshold and weight (seed 004) on "
                              "the regime's training split",
                              wimm_command_);
    fcm_ = add_train_command(
        app, "fcm", "fit the FCM-IMM's parameters (seed 003) on the regime's training split",
        fcm_command_);
    tsk_ = add_train_command(
        app, "tsk",
        "fit the probabilistic TSK model of a range sensor (seed 002): FCRM, then Ceres",
        tsk_command_);
    tsk_->add_option("--data", tsk_data_,
                     "fit these samples (a range-sensor data set .h5 or a CSV xi,eta,z1,z2); they "
                     "must be the sensor samples the regime names");
  }
  TrainingCommands(const TrainingCommands&) = delete;
  TrainingCommands& operator=(const TrainingCommands&) = delete;

  /// The model file of the subcommand the command line chose, if it chose one of these.
  [[nodiscard]] std::optional<std::filesystem::path> chosen_out() const {
    for (const auto& [command, out] : outputs()) {
      if (*command) return out;
    }
    return std::nullopt;
  }

  /// Runs the chosen subcommand; its exit code.
  [[nodiscard]] int run() const {
    if (*ga_) return run_ga(ga_command_);
    if (*freeze_) return run_freeze(freeze_options_);
    if (*mlp_) return train_mlp(mlp_command_);
    if (*wimm_) return train_wimm(wimm_command_);
    if (*tsk_) return train_tsk(tsk_command_, tsk_data_);
    if (*fcm_) return train_fcm(fcm_command_);
    if (*import_) return run_import_rules(import_options_);
    throw std::logic_error("no training subcommand was chosen");
  }

  [[nodiscard]] const CLI::App* ga() const { return ga_; }

 private:
  [[nodiscard]] std::vector<std::pair<const CLI::App*, std::filesystem::path>> outputs() const {
    return {{ga_, ga_command_.out},        {freeze_, freeze_options_.out}, {mlp_, mlp_command_.out},
            {wimm_, wimm_command_.out},    {fcm_, fcm_command_.out},       {tsk_, tsk_command_.out},
            {import_, import_options_.out}};
  }

  GaCommand ga_command_;
  imm::trainer::FreezeOptions freeze_options_;
  imm::trainer::ImportRulesOptions import_options_;
  TrainCommand mlp_command_{
      "configs/mlp_input_estimator.toml", "models/mlp_input_estimator.h5", {}, {}};
  TrainCommand wimm_command_{"configs/wimm.toml", "models/wimm.h5", {}, {}};
  TrainCommand fcm_command_{"configs/fcm_imm.toml", "models/fcm_imm.h5", {}, {}};
  TrainCommand tsk_command_{"configs/tsk_range_sensor.toml", "models/tsk_range_sensor.h5", {}, {}};
  std::filesystem::path tsk_data_;
  CLI::App *freeze_ = nullptr, *ga_ = nullptr, *import_ = nullptr, *mlp_ = nullptr,
           *wimm_ = nullptr, *fcm_ = nullptr, *tsk_ = nullptr;
};

/// A sweep job's arguments parsed as its subcommand's command line; a CLI::ParseError when they
/// are not one.
void parse_job(CLI::App& app, const imm::trainer::SweepJob& job) {
  app.require_subcommand(1);
  std::vector<std::string> reversed(job.arguments.rbegin(), job.arguments.rend());
  app.parse(reversed);  // CLI11 takes a vector in reverse order
}

/// One job of a sweep, exactly as its subcommand runs it. With a log, the training's progress
/// goes there in full (info level, as a single process logs it) whichever rank runs it.
int train_job(const imm::trainer::SweepJob& job, int real_rank) {
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

struct SweepCommand {
  std::filesystem::path plan;
  std::optional<std::filesystem::path> summary;
};

int run_sweep(const SweepCommand& command) {
  const imm::trainer::Ranks& ranks = imm::trainer::Ranks::world();
  const auto plan = imm::trainer::load_sweep_plan(command.plan);
  // Every job's arguments must be its subcommand's command line before anything trains.
  for (std::size_t i = 0; i < plan.jobs.size(); ++i) {
    CLI::App app{"imm-train"};
    const TrainingCommands training(app);
    try {
      parse_job(app, plan.jobs[i]);
    } catch (const CLI::ParseError& error) {
      throw imm::support::ConfigError(command.plan.string(), "jobs",
                                      fmt::format("'{}' is not an imm-train command line: {}",
                                                  plan.jobs[i].name, error.what()));
    }
  }
  // One temporaries guard for every output folder of the plan (see temporaries_guard.hpp).
  std::set<std::filesystem::path> folders;
  for (const auto& job : plan.jobs) {
    folders.insert(job.out.parent_path().empty() ? "." : job.out.parent_path());
  }
  imm::trainer::guard_temporaries({folders.begin(), folders.end()});
  spdlog::info("sweep {}: {} trainings over {} rank{}", command.plan.string(), plan.jobs.size(),
               ranks.size(), ranks.size() == 1 ? "" : "s");
  const auto start = std::chrono::steady_clock::now();
  const int rank = ranks.rank();
  const auto outcomes = imm::trainer::run_sweep(
      plan, [rank](const imm::trainer::SweepJob& job) { return train_job(job, rank); },
      [&](const imm::trainer::SweepJob& job, const imm::trainer::SweepOutcome& o) {
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
  if (command.summary) {
    imm::trainer::write_json_atomically(
        *command.summary, imm::trainer::sweep_summary(plan, outcomes, ranks.size(), seconds));
  }
  if (!failed.empty()) {
    spdlog::error("sweep: {} of {} trainings failed in {:.1f} s: {}", failed.size(),
                  outcomes.size(), seconds, fmt::join(failed, "; "));
    return exit_code::kJobFailed;
  }
  spdlog::info("sweep: {} trainings in {:.1f} s", outcomes.size(), seconds);
  return 0;
}

struct NightlyCommand {
  std::filesystem::path config;
  bool force = false;
  bool sweep = false;
  std::string launcher;
  std::string night;
  std::filesystem::path reports = "reports/nightly";
};

int run_all(const NightlyCommand& command) {
  const auto plan = imm::trainer::load_nightly_plan(command.config);
  imm::trainer::NightlyOptions options;
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
  options.on_finish = [](const imm::trainer::StageOutcome& o) {
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
  const auto result = imm::trainer::run_nightly(plan, options);
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
  imm::trainer::Registry registry(registry_folder);
  const auto found = registry.find(kind, regime);
  if (found.empty()) {
    spdlog::error("rollback: no shipped {} model for regime '{}' in {}", kind, regime,
                  registry.manifest_path().string());
    return exit_code::kBadInput;
  }
  if (found.size() > 1) {
    std::string names;
    for (const auto* e : found) names += " " + e->name;
    spdlog::error("rollback: {} models of kind {} for regime '{}':{}", found.size(), kind, regime,
                  names);
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
  log_as(ranks.rank());
  CLI::App app{"Train immtrain models into model files; run the nightly pipeline."};
  imm::support::standard_options(app, "imm-train");
  app.require_subcommand(1);

  const TrainingCommands training(app);

  NightlyCommand nightly;
  auto* all_command = app.add_subcommand(
      "all", "the nightly: train candidates, evaluate, promote what passes, write the report");
  all_command->add_option("--config", nightly.config, "nightly plan TOML")->required();
  all_command->add_flag("--force", nightly.force, "rerun every stage (ignore the stage cache)");
  all_command->add_option("--night", nightly.night, "report folder name (default: UTC date)");
  all_command->add_option("--reports", nightly.reports, "where the nightly reports go");
  all_command->add_flag("--sweep", nightly.sweep,
                        "train every candidate that is not cached first, in one 'imm-train sweep'");
  all_command->add_option("--launcher", nightly.launcher,
                          "start that sweep with this command, words split at spaces ('mpirun -np "
                          "8', 'srun'); implies --sweep");

  SweepCommand sweep;
  auto* sweep_command = app.add_subcommand(
      "sweep",
      "train many models (kind x regime x seed); under mpirun the ranks take them as they free up");
  sweep_command->add_option("--config", sweep.plan, "sweep plan TOML ([[jobs]])")->required();
  sweep_command->add_option("--summary", sweep.summary,
                            "write every job's outcome there (JSON: exit code, rank, seconds)");

  std::filesystem::path seal_path;
  auto* seal_command = app.add_subcommand(
      "seal",
      "re-seal a model file edited with other tools (h5py), after checking that it still reads");
  seal_command->add_option("file", seal_path, "model file")->required();

  imm::trainer::PromoteOptions promote_options;
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
  auto* rollback_command = app.add_subcommand(
      "rollback", "restore the model a promotion replaced: imm-train rollback KIND [REGIME]");
  rollback_command->add_option("kind", rollback_kind, "model kind or nightly command (ga, …)")
      ->required();
  rollback_command->add_option("regime", rollback_regime,
                               "regime name (omitted: a model trained for no regime)");
  rollback_command->add_option("--registry", rollback_registry, "registry folder (models)");

  if (const auto exit = imm::support::parse(app, argc, argv)) return *exit;
  if (ranks.size() > 1) {
    if (!*training.ga() && !*sweep_command) {
      spdlog::error(
          "imm-train {} runs as one process: under mpirun only 'ga' spreads its work over the "
          "ranks (and 'sweep' hands out whole trainings)",
          app.get_subcommands().front()->get_name());
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
    if (*sweep_command) return run_sweep(sweep);
    if (*rollback_command) return run_rollback(rollback_kind, rollback_regime, rollback_registry);
    if (*promote_command) {
      const auto entry = imm::trainer::promote_by_hand(promote_options);
      spdlog::info("promoted {} as {} ({}, sha256 {}): {}", promote_options.file.string(),
                   entry.name, entry.file, entry.sha256.substr(0, 12), entry.promotion_reason);
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
    spdlog::error("{}", error.what());
    return exit_code::kBadInput;
  } catch (const imm::io::FileError& error) {
    spdlog::error("{}", error.what());
    return exit_code::kBadInput;
  } catch (const std::exception& error) {
    spdlog::error("{}", error.what());
    return exit_code::kBadInput;
  } catch (...) {
    spdlog::error("unexpected error");
    return exit_code::kBadInput;
  }
  return 1;
}

int main(int argc, char** argv) {
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
