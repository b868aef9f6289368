// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/ga/ga_trainer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <future>

#include "imm/datasets/random.hpp"
#include "imm/datasets/sha256.hpp"
#include "imm/io/container_file.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/io/schema_reader.hpp"
#include "imm/trainer/ga/tuned_levels.hpp"
#include "imm/trainer/model_files/write_model.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/ranks.hpp"

namespace imm::trainer::ga {
namespace {

constexpr std::string_view kCheckpointFormat = "immtrain-ga-checkpoint";
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Identifies what a checkpoint was made for: config text, regime and seed.
std::string run_digest(const GaTrainingConfig& config) {
  datasets::Sha256 hash;
  hash.update(config.text);
  hash.update(config.regime.digest);
  hash.update(&config.seed, sizeof config.seed);
  return hash.hex_digest();
}

Eigen::MatrixXd evaluation_rows(const std::vector<Evaluation>& evaluations) {
  Eigen::MatrixXd m(static_cast<Eigen::Index>(evaluations.size()), 5);
  for (std::size_t i = 0; i < evaluations.size(); ++i) {
    const Evaluation& e = evaluations[i];
    m.row(static_cast<Eigen::Index>(i)) << e.fitness, e.error, e.position_error, e.velocity_error,
        e.rules;
  }
  return m;
}

Evaluation evaluation_from(const Eigen::MatrixXd& m, Eigen::Index i) {
  Evaluation e;
  e.fitness = m(i, 0);
  e.error = m(i, 1);
  e.position_error = m(i, 2);
  e.velocity_error = m(i, 3);
  e.rules = static_cast<int>(m(i, 4));
  return e;
}

Eigen::MatrixXd history_rows(const std::vector<GenerationLog>& history) {
  Eigen::MatrixXd m(static_cast<Eigen::Index>(history.size()), 5);
  for (std::size_t i = 0; i < history.size(); ++i) {
    const GenerationLog& h = history[i];
    m.row(static_cast<Eigen::Index>(i)) << h.generation, h.best_fitness, h.mean_fitness,
        h.best_error, h.best_rules;
  }
  return m;
}

std::vector<GenerationLog> history_from(const Eigen::MatrixXd& m) {
  std::vector<GenerationLog> history;
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    history.push_back(
        {static_cast<int>(m(i, 0)), m(i, 1), m(i, 2), m(i, 3), static_cast<int>(m(i, 4))});
  }
  return history;
}

GenerationLog log_of(const Population& population) {
  const Evaluation& best = population.evaluations[population.best_index()];
  return {population.generation, best.fitness, population.mean_fitness(), best.error, best.rules};
}

// --- Checkpoint ------------------------------------------------------------------------------

struct Checkpoint {
  std::vector<LevelResult> finished;
  std::size_t level = 0;
  Population population;
  std::vector<GenerationLog> history;
  double level_seconds = 0.0;
};

void write_checkpoint(const std::filesystem::path& path, const GaTrainingConfig& config,
                      const Checkpoint& checkpoint) {
  io::ContainerWriter writer(path, kCheckpointFormat);
  writer.set_attribute("/", "run_digest", run_digest(config));
  writer.set_attribute("/", "level", static_cast<std::int64_t>(checkpoint.level));
  writer.set_attribute("/", "generation",
                       static_cast<std::int64_t>(checkpoint.population.generation));
  writer.set_attribute("/", "level_seconds", checkpoint.level_seconds);
  writer.set_attribute("/", "finished_levels",
                       static_cast<std::int64_t>(checkpoint.finished.size()));
  for (std::size_t i = 0; i < checkpoint.finished.size(); ++i) {
    const LevelResult& r = checkpoint.finished[i];
    const std::string group = "/finished/level" + std::to_string(i);
    writer.write(group + "/rules", io::rules_matrix(r.table));
    writer.write(group + "/evaluations",
                 evaluation_rows({r.training, r.validation, r.before_memetic}));
    writer.write(group + "/history", history_rows(r.history));
    writer.write(group + "/ranges",
                 io::Array{{4}, {r.residual_ranges.begin(), r.residual_ranges.end()}});
    writer.set_attribute(group, "maneuver_level", r.maneuver_level);
    writer.set_attribute(group, "memetic_evaluations", std::int64_t{r.memetic_evaluations});
    writer.set_attribute(group, "generations", std::int64_t{r.generations});
    writer.set_attribute(group, "wall_seconds", r.wall_seconds);
    writer.set_attribute(group, "training_digest", r.training_digest);
  }
  const Population& p = checkpoint.population;
  const auto n = static_cast<Eigen::Index>(p.genomes.size());
  const auto genes = static_cast<Eigen::Index>(p.genomes.front().genes.size());
  const auto slots = static_cast<Eigen::Index>(p.genomes.front().active.size());
  Eigen::MatrixXd gene_matrix(n, genes), active_matrix(n, slots);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Genome& g = p.genomes[static_cast<std::size_t>(i)];
    for (Eigen::Index j = 0; j < genes; ++j)
      gene_matrix(i, j) = g.genes[static_cast<std::size_t>(j)];
    for (Eigen::Index j = 0; j < slots; ++j)
      active_matrix(i, j) = g.active[static_cast<std::size_t>(j)];
  }
  writer.write("/population/genes", gene_matrix);
  writer.write("/population/active", active_matrix);
  writer.write("/population/evaluations", evaluation_rows(p.evaluations));
  writer.write("/population/history", history_rows(checkpoint.history));
  writer.commit();
}

// Writes checkpoints on a thread of their own, one at a time, while the next generation runs (its
// fsyncs were a tenth of the default training's wall time). submit() waits for the write before
// (rethrowing its failure) and starts this one on a copy of the state; wait() ends the pending
// one. The rest of the training calls no HDF5 (a serial build, not thread-safe) between the two:
// train_ga waits before anything after a level's generations.
class CheckpointWriter {
 public:
  CheckpointWriter(std::filesystem::path path, const GaTrainingConfig& config)
      : path_(std::move(path)), config_(config) {}
  CheckpointWriter(const CheckpointWriter&) = delete;
  CheckpointWriter& operator=(const CheckpointWriter&) = delete;
  ~CheckpointWriter() {
    if (pending_.valid()) pending_.wait();
  }

  void submit(const Checkpoint& state) {
    wait();
    pending_ = std::async(std::launch::async,
                          [this, snapshot = state] { write_checkpoint(path_, config_, snapshot); });
  }
  void wait() {
    if (pending_.valid()) pending_.get();
  }

 private:
  std::filesystem::path path_;
  const GaTrainingConfig& config_;
  std::future<void> pending_;
};

std::optional<Checkpoint> read_checkpoint(const std::filesystem::path& path,
                                          const GaTrainingConfig& config) {
  if (!std::filesystem::exists(path)) return std::nullopt;
  const io::SchemaReader reader(path, kCheckpointFormat);
  if (reader.text("/", "run_digest") != run_digest(config)) {
    reader.fail("/@run_digest",
                "checkpoint of another config or seed; delete it or run without --resume");
  }
  Checkpoint c;
  const auto levels = static_cast<std::int64_t>(config.levels.size());
  const auto finished = reader.integer("/", "finished_levels", 0, levels);
  for (std::int64_t i = 0; i < finished; ++i) {
    const std::string group = "/finished/level" + std::to_string(i);
    LevelResult r;
    r.table = io::table_from_matrix(reader.matrix(group + "/rules", -1, 5));
    const Eigen::MatrixXd evaluations = reader.matrix(group + "/evaluations", 3, 5);
    r.training = evaluation_from(evaluations, 0);
    r.validation = evaluation_from(evaluations, 1);
    r.before_memetic = evaluation_from(evaluations, 2);
    r.history = history_from(reader.matrix(group + "/history", -1, 5));
    const Eigen::VectorXd ranges = reader.vector(group + "/ranges", 4);
    for (int k = 0; k < 4; ++k) r.residual_ranges[static_cast<std::size_t>(k)] = ranges(k);
    r.maneuver_level = reader.real(group, "maneuver_level", io::ValueRule::kNonNegative);
    r.memetic_evaluations =
        static_cast<int>(reader.integer(group, "memetic_evaluations", 0, INT32_MAX));
    r.generations = static_cast<int>(reader.integer(group, "generations", 0, INT32_MAX));
    r.wall_seconds = reader.real(group, "wall_seconds", io::ValueRule::kNonNegative);
    r.training_digest = reader.text(group, "training_digest");
    c.finished.push_back(std::move(r));
  }
  c.level = static_cast<std::size_t>(reader.integer("/", "level", 0, levels));
  c.level_seconds = reader.real("/", "level_seconds", io::ValueRule::kNonNegative);
  c.population.generation =
      static_cast<int>(reader.integer("/", "generation", 0, config.ga.generations));
  const Eigen::MatrixXd genes = reader.matrix("/population/genes", config.ga.population,
                                              config.fuzzy.max_rules * kGenesPerRule);
  const Eigen::MatrixXd active =
      reader.matrix("/population/active", config.ga.population, config.fuzzy.max_rules);
  const Eigen::MatrixXd evaluations =
      reader.matrix("/population/evaluations", config.ga.population, 5);
  for (Eigen::Index i = 0; i < genes.rows(); ++i) {
    Genome g;
    g.genes.assign(genes.row(i).data(), genes.row(i).data() + 0);
    g.genes.resize(static_cast<std::size_t>(genes.cols()));
    for (Eigen::Index j = 0; j < genes.cols(); ++j)
      g.genes[static_cast<std::size_t>(j)] = genes(i, j);
    g.active.resize(static_cast<std::size_t>(active.cols()));
    for (Eigen::Index j = 0; j < active.cols(); ++j) {
      g.active[static_cast<std::size_t>(j)] = active(i, j) != 0.0 ? 1 : 0;
    }
    c.population.genomes.push_back(std::move(g));
    c.population.evaluations.push_back(evaluation_from(evaluations, i));
  }
  c.history = history_from(reader.matrix("/population/history", -1, 5));
  return c;
}

// --- Training --------------------------------------------------------------------------------

nlohmann::json evaluation_json(const Evaluation& e) {
  return {{"fitness", e.fitness},
          {"error", e.error},
          {"position_error", e.position_error},
          {"velocity_error", e.velocity_error},
          {"rules", e.rules}};
}

void write_outputs(const GaTrainingConfig& config, const GaRunOptions& options,
                   const GaTrainingResult& result) {
  datasets::Sha256 digest;
  for (const auto& level : result.levels) digest.update(level.training_digest);
  io::Provenance provenance = provenance_of(io::kGaFuzzyImmKind, config, digest.hex_digest());
  std::vector<std::vector<io::LevelMetric>> level_metrics;
  for (std::size_t i = 0; i < result.levels.size(); ++i) {
    const LevelResult& r = result.levels[i];
    // Fitness and error (eq. 16–17, the error over σ_z) are dimensionless; rules and
    // generations are counts.
    level_metrics.push_back({{"fitness", r.training.fitness},
                             {"error", r.training.error},
                             {"rules", static_cast<std::int64_t>(r.training.rules)},
                             {"validation_error", r.validation.error},
                             {"generations", static_cast<std::int64_t>(r.generations)},
                             {"wall_seconds", r.wall_seconds, "s"}});
    provenance.training_metrics["error_level" + std::to_string(i)] = r.training.error;
    provenance.validation_metrics["error_level" + std::to_string(i)] = r.validation.error;
  }
  if (result.baseline_check) {
    const BaselineCheck& c = *result.baseline_check;
    provenance.training_metrics["learned_part_on"] = c.learned_part_on ? 1.0 : 0.0;
    provenance.validation_metrics["error_learned"] = c.learned.error;
    provenance.validation_metrics["error_tuned_baseline"] = c.baseline.error;
  }
  write_model_file(options.out, provenance, [&](io::ModelFileWriter& writer) {
    io::write_ga_fuzzy_imm(writer, spec_from(config, result.levels), level_metrics);
  });

  nlohmann::json metrics = metrics_of(io::kGaFuzzyImmKind, options.out, config.name);
  metrics["seed"] = config.seed;
  metrics["regime"] = config.regime.name;
  metrics["fitness"] = std::string(to_string(config.fuzzy.fitness));
  metrics["error"] = std::string(to_string(config.fuzzy.error));
  metrics["wall_seconds"] = result.wall_seconds;
  if (config.baseline) {
    metrics["baseline"] = {
        {"process_noise", config.baseline->process_noise},
        {"transition_stay", config.baseline->transition_stay},
        {"training_criterion",
         !config.regime.trains_from_truth() ? "excess NLL per plot" : "ζ_p + ζ_v"},
        {"training_zeta_p_plus_zeta_v", config.baseline->score},
        {"evaluations", config.baseline->evaluations}};
  }
  if (result.refinement) {
    const LevelRefinement& r = *result.refinement;
    metrics["refinement"] = {{"before", evaluation_json(r.before)},
                             {"after", evaluation_json(r.after)},
                             {"factors", r.factors},
                             {"transition_stay", r.transition_stay},
                             {"evaluations", r.evaluations},
                             {"accepted", r.accepted}};
  }
  if (result.baseline_check) {
    const BaselineCheck& c = *result.baseline_check;
    metrics["against_baseline"] = {{"validation_learned", evaluation_json(c.learned)},
                                   {"validation_baseline", evaluation_json(c.baseline)},
                                   {"learned_part_on", c.learned_part_on}};
  }
  metrics["transition_stay"] = config.filter.transition_stay;
  for (const LevelResult& r : result.levels) {
    nlohmann::json level;
    level["maneuver_level"] = r.maneuver_level;
    level["training"] = evaluation_json(r.training);
    level["validation"] = evaluation_json(r.validation);
    level["before_memetic"] = evaluation_json(r.before_memetic);
    level["memetic_evaluations"] = r.memetic_evaluations;
    level["generations"] = r.generations;
    level["wall_seconds"] = r.wall_seconds;
    level["residual_ranges"] = r.residual_ranges;
    nlohmann::json history = nlohmann::json::array();
    for (const GenerationLog& h : r.history) {
      history.push_back({h.generation, h.best_fitness, h.mean_fitness, h.best_error, h.best_rules});
    }
    level["history_columns"] = {"generation", "best_fitness", "mean_fitness", "best_error",
                                "best_rules"};
    level["history"] = history;
    metrics["levels"].push_back(level);
  }
  write_json_atomically(metrics_path(options.out), metrics);
}

}  // namespace

std::filesystem::path checkpoint_path(const std::filesystem::path& model) {
  return model.parent_path() / (model.filename().string() + ".checkpoint");
}

std::string level_name(double maneuver_level) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "u%g", maneuver_level);
  return buffer;
}

GaFuzzyImmSpec spec_from(const GaTrainingConfig& config, const std::vector<LevelResult>& levels) {
  GaFuzzyImmSpec spec;
  spec.settings = config.filter;
  spec.antecedents = config.fuzzy.antecedents;
  for (const LevelResult& r : levels) {
    spec.levels.push_back({level_name(r.maneuver_level), r.maneuver_level, r.table});
  }
  return spec;
}

GaTrainingResult train_ga(const GaTrainingConfig& requested, const GaRunOptions& options,
                          const GaObserver& observer) {
  requested.validate();
  const Ranks& ranks = Ranks::world();
  const auto run_start = Clock::now();
  const std::filesystem::path checkpoint_file = checkpoint_path(options.out);
  ensure_parent_folder(options.out);

  // Every level's table learns on the regime's training split (the IMM fitness scores each in its
  // slot of the IMM that sees every maneuver the regime has; the single-filter fitness gives each
  // level its own consequent range of eq. 15 on the same data).
  const TrainingSet training = make_training_set(requested.regime, datasets::Split::kTraining);
  const TrainingSet validation = make_training_set(requested.regime, datasets::Split::kValidation);
  require(!training.plots_only || (requested.fuzzy.fitness == FitnessKind::kImm &&
                                   requested.fuzzy.error == ErrorKind::kZeta),
          "training.error",
          "regime '" + requested.regime.name +
              "' has no truth to train on: the GA learns from the plots' predictive likelihood "
              "only with fitness = \"imm\" and error = \"zeta\" (configs/ga_fuzzy_imm_tuned.toml)");
  GaTrainingConfig config = resolve_levels(requested, training);

  std::optional<Checkpoint> resumed;
  if (options.resume) resumed = read_checkpoint(checkpoint_file, config);

  GaTrainingResult result;
  std::size_t first_level = 0;
  if (resumed) {
    result.levels = resumed->finished;
    first_level = resumed->level;
  }

  const bool imm_fitness = config.fuzzy.fitness == FitnessKind::kImm;

  for (std::size_t level = first_level; level < config.levels.size(); ++level) {
    ImmContext context;
    if (imm_fitness) {
      // Levels trained so far keep their tables; the others stand in with the constant q of the
      // top of eq. (15), where the single-filter GA ends anyway (tuned levels: the tuned IMM's
      // q_j, so the first candidate context is the tuned IMM itself).
      context.settings = config.filter;
      context.slot = level;
      for (std::size_t j = 0; j < config.levels.size(); ++j) {
        const ProblemOptions level_options = config.problem_options(j);
        const double s = level_options.maneuver_level + level_options.process_noise_sigma;
        FuzzyLevel stand_in{level_name(config.levels[j]), config.levels[j],
                            FuzzyRuleTable({{0.0, 1.0, 0.0, 1.0, s * s}})};
        if (j < result.levels.size()) stand_in.table = result.levels[j].table;
        context.levels.push_back(std::move(stand_in));
      }
    }
    const FuzzyTableProblem problem(training, config.problem_options(level), context);
    const GeneticAlgorithm algorithm(problem, config.ga, datasets::derive_seed(config.seed, level));

    Checkpoint state;
    state.finished = result.levels;
    state.level = level;
    double earlier_seconds = 0.0;
    if (resumed && resumed->level == level) {
      state.population = std::move(resumed->population);
      state.history = std::move(resumed->history);
      earlier_seconds = resumed->level_seconds;
      if (observer.on_resume) observer.on_resume(level, state.population.generation);
      resumed.reset();
    } else {
      std::vector<Genome> seeds;
      if (config.tuned_levels) seeds.push_back(problem.constant_genome(config.levels[level]));
      state.population = algorithm.initialize(seeds);
      state.history = {log_of(state.population)};
    }
    const auto level_start = Clock::now();
    // The root writes; every rank stops when any is asked to (they must leave together), with
    // the checkpoint of the generation it stopped at written.
    CheckpointWriter writer(checkpoint_file, config);
    auto checkpoint = [&] {
      state.level_seconds = earlier_seconds + seconds_since(level_start);
      if (ranks.root()) writer.submit(state);
      const bool stop = ranks.any(observer.should_stop && observer.should_stop());
      if (stop) writer.wait();
      return stop;
    };
    if (observer.on_generation)
      observer.on_generation(level, state.history.back(), earlier_seconds);
    if (checkpoint()) {
      result.stopped = true;
      return result;
    }
    while (state.population.generation < config.ga.generations) {
      algorithm.evolve(state.population);
      state.history.push_back(log_of(state.population));
      if (observer.on_generation) {
        observer.on_generation(level, state.history.back(),
                               earlier_seconds + seconds_since(level_start));
      }
      if (checkpoint()) {
        result.stopped = true;
        return result;
      }
    }
    writer.wait();

    const Genome& best = state.population.genomes[state.population.best_index()];
    const MemeticResult polished = polish(problem, best, config.memetic);
    LevelResult r;
    r.maneuver_level = config.levels[level];
    r.table = problem.decode(polished.genome);
    r.training = polished.after;
    r.before_memetic = polished.before;
    r.memetic_evaluations = polished.evaluations;
    r.validation = problem.evaluate_table(r.table, validation);
    r.generations = state.population.generation;
    r.wall_seconds = earlier_seconds + seconds_since(level_start);
    r.residual_ranges = problem.residual_ranges();
    r.history = state.history;
    r.training_digest = training.digest();
    if (observer.on_level_done) observer.on_level_done(level, r);
    result.levels.push_back(std::move(r));
  }

  if (config.refine_levels || config.baseline) {
    // The continuous parameters with the tables, then the tuned IMM's check: on the whole spec.
    GaFuzzyImmSpec spec = spec_from(config, result.levels);
    if (config.refine_levels) result.refinement = refine_levels(spec, config, training);
    if (config.baseline) result.baseline_check = check_against_baseline(spec, config, validation);
    config.filter.transition_stay = spec.settings.transition_stay;
    for (std::size_t j = 0; j < result.levels.size(); ++j) {
      LevelResult& r = result.levels[j];
      r.table = spec.levels[j].table;
      r.maneuver_level = spec.levels[j].maneuver_level;
      // Every level's scores are now those of the final IMM.
      const ProblemOptions level_options = config.problem_options(j);
      const int own = static_cast<int>(r.table.size());
      r.training = evaluate_imm(spec, training, level_options, own);
      r.validation = evaluate_imm(spec, validation, level_options, own);
    }
  }
  result.config = config;
  result.wall_seconds = seconds_since(run_start);
  result.gate_passed = true;
  for (std::size_t i = 0; i < result.levels.size(); ++i) {
    const double error = result.levels[i].validation.error;
    if (!(error <= config.max_validation_error)) {
      result.gate_passed = false;
      result.gate_message = "level " + level_name(result.levels[i].maneuver_level) +
                            ": validation error " + std::to_string(error) + " exceeds " +
                            std::to_string(config.max_validation_error);
    }
  }
  if (!ranks.root()) return result;
  if (result.gate_passed) write_outputs(config, options, result);
  // The run is complete either way: a resume would only repeat the verdict. (A run that stops
  // early — killed, stopped, or an error — keeps its checkpoint for --resume.)
  std::error_code ignored;
  std::filesystem::remove(checkpoint_file, ignored);
  return result;
}

}  // namespace imm::trainer::ga
