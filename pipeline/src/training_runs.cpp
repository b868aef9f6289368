// SPDX-License-Identifier: Apache-2.0
// What each training subcommand of imm-train runs once its command line is parsed: the training,
// its progress lines and its exit code (training_commands.cpp describes the subcommands).
#include "training_runs.hpp"

#include <omp.h>
#include <spdlog/fmt/ranges.h>
#include <spdlog/spdlog.h>

#include "imm/datasets/random.hpp"
#include "imm/datasets/regime_file.hpp"
#include "imm/support/config.hpp"
#include "imm/support/exit_codes.hpp"
#include "imm/trainer/classical/classical_imm.hpp"
#include "imm/trainer/classical/noise_schedule.hpp"
#include "imm/trainer/fcm/fcm_trainer.hpp"
#include "imm/trainer/ga/ga_trainer.hpp"
#include "imm/trainer/ga/tuned_baseline_file.hpp"
#include "imm/trainer/learning_curve.hpp"
#include "imm/trainer/mlp/mlp_trainer.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/ranks.hpp"
#include "imm/trainer/tsk/tsk_trainer.hpp"
#include "imm/trainer/wimm/wimm_trainer.hpp"

namespace imm::pipeline {
namespace {

namespace exit_code = support::exit_code;

// A wIMM config (its [filter] names the Singer mode) gives a polar regime's baseline, the tuned
// normal IMM; any other config is read as a GA config (a Cartesian regime's constant-q IMM).
bool is_wimm_config(const std::filesystem::path& path) {
  const auto document = support::ConfigDocument::load(path);
  const auto filter = document->root().table("filter");
  return filter && filter->has("singer_tau");
}

}  // namespace

int run_ga(const GaCommand& command) {
  namespace ga = trainer::ga;
  ga::GaTrainingConfig config = ga::load_ga_config(command.config, command.regime);
  if (command.seed) config.seed = *command.seed;
  if (command.threads > 0) omp_set_num_threads(command.threads);
  if (config.tuned_levels) {
    const trainer::TrainingSet training =
        trainer::make_training_set(config.regime, datasets::Split::kTraining);
    config = ga::resolve_levels(std::move(config), training);
    spdlog::info(
        "ga: starting from the constant-q IMM tuned on the training split: q [{}], stay {:.4f}, "
        "{} {:.4f} ({} evaluations)",
        fmt::join(config.baseline->process_noise, ", "), config.baseline->transition_stay,
        training.criterion(), config.baseline->score, config.baseline->evaluations);
  }
  if (!config.tuned_levels) {
    const auto warning = ga::unreachable_quiet_level(
        config, trainer::make_training_set(config.regime, datasets::Split::kTraining));
    if (warning) spdlog::warn("ga: levels: {}", *warning);
  }
  const std::size_t levels = config.levels.size();
  const int generations = config.ga.generations;
  spdlog::info("ga: regime {}, levels [{}] {}, population {}, {} generations, seed {}, {} threads",
               config.regime.name, fmt::join(config.levels, ", "),
               datasets::to_string(config.regime.units) == "km" ? "km/s²" : "m/s²",
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
  if (result.refinement) {
    const ga::LevelRefinement& r = *result.refinement;
    spdlog::info("levels and stay refined jointly ({} evaluations): error {:.4f} -> {:.4f}{}",
                 r.evaluations, r.before.error, r.after.error,
                 r.accepted ? fmt::format(", factors on w [{:.3g}], stay {:.4f}",
                                          fmt::join(r.factors, ", "), r.transition_stay)
                            : std::string(" (no gain, unchanged)"));
  }
  if (result.baseline_check) {
    const ga::BaselineCheck& c = *result.baseline_check;
    // Without truth the rule has two parts: the excess NLL and the innovation RMS.
    const std::string rms = c.baseline_innovation_rms > 0.0
                                ? fmt::format("; innovation RMS {:.4f} against {:.4f} σ",
                                              c.learned_innovation_rms, c.baseline_innovation_rms)
                                : std::string();
    if (c.learned_part_on) {
      spdlog::info(
          "validation split: the learned tables beat the tuned IMM (error {:.4f} < "
          "{:.4f}{})",
          c.learned.error, c.baseline.error, rms);
    } else {
      spdlog::warn(
          "validation split: the learned tables do not beat the tuned IMM (error {:.4f} against "
          "{:.4f}{}): learned part switched off, the model is the tuned constant-q IMM",
          c.learned.error, c.baseline.error, rms);
      if (const std::string small =
              trainer::small_split_warning("ga", config.regime.splits.training, config.regime.name);
          !small.empty()) {
        spdlog::warn("{}", small);
      }
    }
  }
  if (!result.gate_passed) {
    spdlog::error("quality gate failed: {}; {} not written", result.gate_message,
                  command.out.string());
    return exit_code::kTrainingGateFailed;
  }
  spdlog::info("wrote {} and {} ({:.1f} s)", command.out.string(),
               trainer::metrics_path(command.out).string(), result.wall_seconds);
  const trainer::Ranks& ranks = trainer::Ranks::world();
  if (ranks.distributed()) {
    spdlog::info(
        "{} ranks: the root sent {} bytes in {} messages to the others, {:.3f} s in "
        "exchanges (waiting for the slowest rank included)",
        ranks.size(), ranks.bytes_sent(), ranks.messages_sent(), ranks.exchange_seconds());
  }
  return 0;
}

int train_mlp(const TrainCommand& command) {
  auto config = trainer::mlp::load_mlp_config(command.config, command.regime);
  if (command.seed) config.seed = *command.seed;
  if (command.seed) config.training.seed = datasets::derive_seed(config.seed, 3);
  int epochs = 0;
  for (const auto& phase : config.training.phases) epochs += phase.epochs;
  spdlog::info("mlp: regime {}, {} training and {} validation tracks, {} epochs, seed {}",
               config.regime.name, config.regime.splits.training, config.regime.splits.validation,
               epochs, config.seed);
  // Live progress: about eight lines over the run, each as its epoch is reached.
  const std::string unit(datasets::to_string(config.regime.units));
  config.training.on_point = [&, every = std::max(1, epochs / 8), next = 0](const auto& p) mutable {
    if (p.epoch < next && p.epoch != epochs) return;
    next = p.epoch + every;
    spdlog::info("epoch {:5}/{}: training MSE {:.4f}, validation MSE {:.4f} ({}/s²)²", p.epoch,
                 epochs, p.training, p.validation, unit);
  };
  const auto result = trainer::mlp::train_mlp(config, command.out);
  spdlog::info(
      "trained in {:.2f} s (back-propagation {:.2f} s): RMSE {:.3f} / {:.3f} {}/s² "
      "(training / validation); no-maneuver output {:.3f} {}/s² before, {:.3f} after "
      "removing the trained bias",
      result.wall_seconds, result.training_seconds, result.training_rmse, result.validation_rmse,
      unit, result.bias_before, unit, result.bias_after);
  if (result.smoother) {
    spdlog::info(
        "labels (no truth): the accelerations of the RTS smoother of the constant-q IMM tuned on "
        "the training plots (q [{}] ({}/s²)², stay {:.4f}); the RMSE above is against them",
        fmt::join(result.smoother->process_noise, ", "), unit,
        result.smoother->settings.transition_stay);
  }
  if (!result.gate_passed) {
    spdlog::error(
        "quality gate failed: validation RMSE {:.3f} {}/s² exceeds {:.3f}; {} not written",
        result.validation_rmse, unit, config.max_validation_rmse, command.out.string());
    return exit_code::kTrainingGateFailed;
  }
  spdlog::info("wrote {}", command.out.string());
  return 0;
}

int train_wimm(const TrainCommand& command) {
  auto config = trainer::wimm::load_wimm_config(command.config, command.regime);
  if (command.seed) config.seed = *command.seed;
  spdlog::info("wimm: tuning threshold and alpha on regime {}: {} training tracks of {} scans",
               config.regime.name, config.regime.splits.training, config.regime.scans);
  const auto result = trainer::wimm::train_wimm(config, command.out);
  if (result.base) {
    spdlog::info(
        "wimm: on top of the nIMM tuned on the training split: q1 {:.4g}, P(CV->CV) {:.4f} "
        "({} evaluations); {} on the validation split {:.4f} against it",
        result.base->spec.cv_process_noise, result.base->spec.transition(0, 0),
        result.base->evaluations, result.with_truth ? "J" : "the excess NLL per plot (no truth)",
        result.validation_objective);
    if (!result.learned_part_on) {
      spdlog::warn(
          "wimm: learned part switched off: the fusion does not beat its tuned nIMM on the "
          "training and validation splits; the model is that nIMM (fusion none)");
    }
  }
  const auto& tuned = result.tuned;
  if (result.with_truth) {
    spdlog::info(
        "threshold {:.4f}, alpha {:.4f}: settled azimuth RMSE x{:.4f}, position RMSE "
        "x{:.4f} of the normal IMM on the training scenarios ({} evaluations, {:.1f} s); "
        "wrote {}",
        tuned.spec.threshold, tuned.spec.alpha, tuned.azimuth_ratio, tuned.position_ratio,
        tuned.evaluations, result.wall_seconds, command.out.string());
  } else {
    spdlog::info(
        "threshold {:.4f}, alpha {:.4f}: excess NLL per plot {:.4f} (the normal IMM's {:.4f}), "
        "innovation RMS {:.3f} σ (its {:.3f} σ) on the training recordings, no truth ({} "
        "evaluations, {:.1f} s); wrote {}",
        tuned.spec.threshold, tuned.spec.alpha, tuned.plots.excess_nll,
        tuned.reference_plots.excess_nll, tuned.plots.innovation_rms,
        tuned.reference_plots.innovation_rms, tuned.evaluations, result.wall_seconds,
        command.out.string());
  }
  return 0;
}

int train_tsk(const TskCommand& command) {
  auto config = trainer::tsk::load_tsk_config(command.config, command.regime);
  if (command.seed) config.seed = *command.seed;
  const auto samples = command.data.empty()
                           ? trainer::tsk::calibration_samples(config)
                           : trainer::tsk::load_sensor_samples(command.data, config);
  spdlog::info(
      "tsk: {} samples from {} ({:.0f} % held out), {} rules per output, t-norm {}, seed {}",
      samples.data.positions.rows(), samples.source, 100.0 * config.validation_fraction,
      config.fcrm.clusters, imm::to_string(config.t_norm), config.seed);
  const auto result = trainer::tsk::train_tsk(config, samples, command.out);
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
  auto config = trainer::fcm::load_fcm_config(command.config, command.regime);
  if (command.seed) config.seed = *command.seed;
  spdlog::info(
      "fcm: regime {}: fitting on {} training tracks ({} held out, {} scans, seed {}), "
      "windows {}",
      config.regime.name, config.regime.splits.training, config.regime.splits.validation,
      config.regime.scans, config.seed, fmt::join(config.tuning.windows, ", "));
  const auto result = trainer::fcm::train_fcm(config, command.out);
  const auto& s = result.spec;
  // With the learned part off the clustering settings are unused: the model is the tuned IMM.
  const std::string learned =
      result.learned_part_on
          ? fmt::format("window {}, lambda {:.3f}, m {:.2f}, kappa {:.2f}", s.window,
                        s.compensation_gain, s.clustering.fuzzifier, s.separation)
          : std::string("the constant-q IMM (learned part off, lambda 0)");
  spdlog::info(
      "fitted: {}, stay {:.4f}, q = {:.4g} ({}/s^2)^2; J = {:.4f} training, {:.4f} validation "
      "(lambda = 0 IMM {:.4f}, KF {:.4f}); {} evaluations, {:.1f} s",
      learned, s.transition(0, 0), fmt::join(s.process_noise, ", "),
      datasets::to_string(config.regime.units), result.training.objective,
      result.validation.objective, result.imm_validation.objective, result.kf_validation.objective,
      result.evaluations, result.wall_seconds);
  if (!result.learned_part_on) {
    if (const std::string small =
            trainer::small_split_warning("fcm", config.regime.splits.training, config.regime.name);
        !small.empty()) {
      spdlog::warn("{}", small);
    }
  }
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

int run_freeze(const trainer::FreezeOptions& options) {
  const auto summary = trainer::freeze_plain_imm(options);
  spdlog::info("froze {} ({} modes, {}-state mixing space) into {} in {:.3f} s",
               options.config.string(), summary.modes, summary.state_dimension,
               options.out.string(), summary.wall_seconds);
  return 0;
}

int run_import_rules(const trainer::ImportRulesOptions& options) {
  const auto spec = trainer::import_rules(options);
  std::size_t rules = 0;
  for (const auto& level : spec.levels) rules += level.table.size();
  spdlog::info("imported {} levels ({} rules) from {} into {}", spec.levels.size(), rules,
               options.csv.string(), options.out.string());
  return 0;
}

// `imm-train schedule`: noise schedules learned on the tuned CV/CA/CT IMM of the config's
// [classical] search (the same IMM `imm-train baseline` writes from the config).
int run_schedule(const TrainCommand& command) {
  namespace classical = trainer::classical;
  classical::ClassicalImmConfig config =
      classical::load_classical_config(command.config, command.regime);
  if (!config.schedule_evaluations) {
    throw support::ConfigError(command.config.string(), "schedule",
                               "missing (the schedule's search; see "
                               "configs/scheduled_ct_imm.toml)");
  }
  if (command.seed) config.seed = *command.seed;
  const classical::ClassicalImmResult result = classical::write_classical_imm(config, command.out);
  const classical::LearnedSchedule& schedule = *result.schedule;
  spdlog::info(
      "schedule: noise schedules on the tuned IMM (modes {}): {} {:.4f} -> {:.4f} on the training "
      "split, {:.4f} -> {:.4f} on the validation split ({} evaluations): learned part {}; wrote {} "
      "({:.1f} s)",
      classical::to_string(result.tuned.modes), result.tuned.criterion,
      schedule.training_base.objective, schedule.training.objective,
      schedule.validation_base.objective, schedule.validation.objective, schedule.evaluations,
      schedule.on ? "on" : "off (the file is the tuned IMM itself)", command.out.string(),
      result.wall_seconds);
  if (!result.small_split_warning.empty()) spdlog::warn("{}", result.small_split_warning);
  return 0;
}

int run_baseline(const TrainCommand& given) {
  TrainCommand command = given;
  // Without --config the default is the GA config, whose filter is Cartesian: a polar regime's
  // classical bar is the normal IMM of the wIMM config; a range sensor's has no file of its own.
  if (!command.config_given && command.regime) {
    const datasets::Regime regime = datasets::load_regime(*command.regime).regime;
    if (regime.sensor.kind == datasets::SensorKind::kPolar) {
      command.config = "configs/wimm_tuned.toml";
    } else if (regime.sensor.kind == datasets::SensorKind::kRangeSensor) {
      throw support::ConfigError(
          command.regime->string(), "sensor.kind",
          "regime '" + regime.name +
              "' has a range sensor: its classical bar is the IMM (h = identity) that `imm-eval "
              "fimm` runs beside the FIMM on the same plots, not a file `imm-train baseline` "
              "writes");
    }
  }
  if (trainer::classical::is_classical_config(command.config)) {
    namespace classical = trainer::classical;
    classical::ClassicalImmConfig config =
        classical::load_classical_config(command.config, command.regime);
    config.schedule_evaluations.reset();  // the baseline is the classical IMM alone
    if (command.seed) config.seed = *command.seed;
    const classical::ClassicalImmResult result =
        classical::write_classical_imm(config, command.out);
    const classical::TunedClassicalImm& tuned = result.tuned;
    std::string tried;
    for (const auto& [set, value] : tuned.tried) {
      tried += (tried.empty() ? "" : ", ") + set + fmt::format(" {:.4f}", value);
    }
    spdlog::info(
        "baseline: the classical IMM tuned on the training split: modes {} (of {}), stay {:.4f}, "
        "{} {:.4f} ({} evaluations); wrote {} ({:.1f} s)",
        classical::to_string(tuned.modes), tried, tuned.spec.transition(0, 0), tuned.criterion,
        tuned.score.objective, tuned.evaluations, command.out.string(), result.wall_seconds);
    return 0;
  }
  if (is_wimm_config(command.config)) {
    trainer::wimm::WimmTrainingConfig config =
        trainer::wimm::load_wimm_config(command.config, command.regime);
    if (command.seed) config.seed = *command.seed;
    const auto result = trainer::wimm::write_tuned_normal_imm_baseline(config, command.out);
    const trainer::wimm::Tuned& base = result.base;
    spdlog::info(
        "baseline: the normal IMM tuned on the training split: q1 {:.4g}, P(CV->CV) {:.4f} ({} "
        "evaluations); wrote {} ({:.1f} s)",
        base.spec.cv_process_noise, base.spec.transition(0, 0), base.evaluations,
        command.out.string(), result.wall_seconds);
    return 0;
  }
  namespace ga = trainer::ga;
  ga::GaTrainingConfig config = ga::load_ga_config(command.config, command.regime);
  if (command.seed) config.seed = *command.seed;
  const ga::TunedBaselineResult result = ga::write_tuned_baseline(std::move(config), command.out);
  spdlog::info(
      "baseline: the constant-q IMM tuned on the training split: q [{}], stay {:.4f}, {} "
      "{:.4f} ({} evaluations); wrote {} ({:.1f} s)",
      fmt::join(result.baseline.process_noise, ", "), result.baseline.transition_stay,
      result.criterion, result.baseline.score, result.baseline.evaluations, command.out.string(),
      result.wall_seconds);
  return 0;
}

}  // namespace imm::pipeline
