#include "imm/trainer/ga/ga_config.hpp"

#include <cmath>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/datasets/random.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/training_config.hpp"

namespace imm::trainer::ga {
namespace {

bool finite_positive(double x) { return std::isfinite(x) && x > 0.0; }

GaTrainingConfig config_from(const support::ConfigTable& root) {
  GaTrainingConfig c;
  c.seed = root.seed_or("seed", 1);
  if (const auto f = root.table("filter")) {
    c.filter.sample_period = f->real_or("sample_period", c.filter.sample_period);
    c.filter.measurement_sigma = f->real_or("measurement_sigma", c.filter.measurement_sigma);
    c.filter.transition_stay = f->real_or("transition_stay", c.filter.transition_stay);
    c.filter.initial_first_probability =
        f->real_or("initial_first_probability", c.filter.initial_first_probability);
  }
  if (const auto t = root.table("training")) {
    TrainingOptions& o = c.training;
    if (t->has("levels")) {
      const Eigen::VectorXd levels = t->reals("levels");
      o.levels.assign(levels.data(), levels.data() + levels.size());
    }
    o.process_noise_sigma = t->real_or("process_noise_sigma", o.process_noise_sigma);
    if (t->has("profile")) {
      const std::string profile = t->text("profile");
      if (profile == "maneuver") {
        o.profile = TrainingProfile::kManeuver;
      } else if (profile == "mixed") {
        o.profile = TrainingProfile::kMixed;
      } else {
        t->fail("profile", "unknown profile '" + profile + "' (expected maneuver or mixed)");
      }
    }
    if (t->has("fitness")) {
      const std::string fitness = t->text("fitness");
      if (fitness == "single") {
        c.fuzzy.fitness = FitnessKind::kSingleFilter;
      } else if (fitness == "imm") {
        c.fuzzy.fitness = FitnessKind::kImm;
      } else {
        t->fail("fitness", "unknown fitness '" + fitness + "' (expected single or imm)");
      }
    }
    o.trajectories = t->count_or("trajectories", o.trajectories);
    o.validation_trajectories = t->count_or("validation_trajectories", o.validation_trajectories);
    o.steps = t->count_or("steps", o.steps);
    if (t->has("segment_length")) {
      const Eigen::VectorXd range = t->reals("segment_length", 2);
      o.min_segment = static_cast<int>(range(0));
      o.max_segment = static_cast<int>(range(1));
    }
    o.initial_speed = t->real_or("initial_speed", o.initial_speed);
  }
  if (const auto f = root.table("fuzzy")) {
    c.fuzzy.max_rules = f->count_or("max_rules", c.fuzzy.max_rules);
    if (f->has("sigma_range")) {
      const Eigen::VectorXd range = f->reals("sigma_range", 2);
      c.fuzzy.sigma_min = range(0);
      c.fuzzy.sigma_max = range(1);
    }
    if (f->has("consequent_range")) {
      const Eigen::VectorXd range = f->reals("consequent_range", 2);
      c.fuzzy.consequent_low = range(0);
      c.fuzzy.consequent_high = range(1);
    }
  }
  if (const auto g = root.table("ga")) {
    GaOptions& o = c.ga;
    o.population = g->count_or("population", o.population);
    o.generations = g->count_or("generations", o.generations);
    o.crossover_rate = g->real_or("crossover_rate", o.crossover_rate);
    o.mutation_rate = g->real_or("mutation_rate", o.mutation_rate);
    c.fuzzy.lambda = g->real_or("lambda", c.fuzzy.lambda);
    o.elite = g->count_or("elite", o.elite);
    o.tournament_size = g->count_or("tournament_size", o.tournament_size);
    o.initial_rule_probability = g->real_or("initial_rule_probability", o.initial_rule_probability);
    o.mutation_scale = g->real_or("mutation_scale", o.mutation_scale);
  }
  if (const auto m = root.table("memetic")) {
    c.memetic.enabled = m->boolean_or("enabled", c.memetic.enabled);
    c.memetic.max_evaluations = m->count_or("max_evaluations", c.memetic.max_evaluations);
  }
  if (const auto gate = root.table("gate")) {
    c.max_validation_error = gate->real_or("max_validation_error", c.max_validation_error);
  }
  c.validate();
  return c;
}

}  // namespace

void GaTrainingConfig::validate() const {
  try {
    filter.validate();
  } catch (const InvalidParameter& error) {
    throw error.within("filter.");
  }
  const TrainingOptions& t = training;
  require(!t.levels.empty() && t.levels.size() <= 8, "training.levels", "need 1 to 8 levels");
  for (double u : t.levels) limits::require_in(u, limits::kAcceleration, "training.levels");
  limits::require_in(t.process_noise_sigma, limits::kAcceleration, "training.process_noise_sigma");
  require(t.trajectories >= 1 && t.trajectories <= 10000, "training.trajectories",
          "must be in [1, 10000]");
  require(t.validation_trajectories >= 1 && t.validation_trajectories <= 10000,
          "training.validation_trajectories", "must be in [1, 10000]");
  require(t.steps >= 10 && t.steps <= 100000, "training.steps", "must be in [10, 100000]");
  require(t.min_segment >= 1 && t.max_segment >= t.min_segment, "training.segment_length",
          "must be [min, max] with 1 ≤ min ≤ max");
  limits::require_magnitude(t.initial_speed, limits::kSpeed, "training.initial_speed");
  require(fuzzy.max_rules >= 1 && fuzzy.max_rules <= 50, "fuzzy.max_rules", "must be in [1, 50]");
  limits::require_in(fuzzy.sigma_min, limits::kSigma, "fuzzy.sigma_range");
  limits::require_in(fuzzy.sigma_max, limits::kSigma, "fuzzy.sigma_range");
  require(fuzzy.sigma_max > fuzzy.sigma_min, "fuzzy.sigma_range",
          "must be [min, max] with 0 < min < max");
  // √w in units of a_M + √q (eq. 15): a table's variances then stay within (1000 a_M)².
  require(std::isfinite(fuzzy.consequent_low) && fuzzy.consequent_low >= 0.0 &&
              fuzzy.consequent_high > fuzzy.consequent_low && fuzzy.consequent_high <= 1000.0,
          "fuzzy.consequent_range", "must be [low, high] with 0 ≤ low < high ≤ 1000");
  require(fuzzy.lambda >= 0.0 && fuzzy.lambda <= 1.0, "ga.lambda", "must be in [0, 1]");
  require(ga.population >= 2 && ga.population <= 100000, "ga.population", "must be in [2, 100000]");
  require(ga.generations >= 0 && ga.generations <= 100000, "ga.generations",
          "must be in [0, 100000]");
  require(ga.crossover_rate >= 0.0 && ga.crossover_rate <= 1.0, "ga.crossover_rate",
          "must be in [0, 1]");
  require(ga.mutation_rate >= 0.0 && ga.mutation_rate <= 1.0, "ga.mutation_rate",
          "must be in [0, 1]");
  require(ga.elite >= 0 && ga.elite < ga.population, "ga.elite", "must be in [0, population)");
  require(ga.tournament_size >= 1 && ga.tournament_size <= ga.population, "ga.tournament_size",
          "must be in [1, population]");
  require(ga.initial_rule_probability > 0.0 && ga.initial_rule_probability <= 1.0,
          "ga.initial_rule_probability", "must be in (0, 1]");
  require(finite_positive(ga.mutation_scale) && ga.mutation_scale <= 1.0, "ga.mutation_scale",
          "must be in (0, 1]");
  require(memetic.max_evaluations >= 0, "memetic.max_evaluations", "must be non-negative");
  require(finite_positive(max_validation_error), "gate.max_validation_error", "must be positive");
  require(memetic.max_evaluations <= 1000000, "memetic.max_evaluations", "must be at most 10⁶");
}

TrainingSetOptions GaTrainingConfig::training_set_options(std::size_t level,
                                                          bool validation) const {
  TrainingSetOptions o;
  o.sample_period = filter.sample_period;
  o.measurement_sigma = filter.measurement_sigma;
  o.process_noise_sigma = training.process_noise_sigma;
  o.maneuver_level = training.levels[level];
  o.profile = training.profile;
  o.trajectories = validation ? training.validation_trajectories : training.trajectories;
  o.steps = training.steps;
  o.min_segment = training.min_segment;
  o.max_segment = training.max_segment;
  o.initial_speed = training.initial_speed;
  o.seed = datasets::derive_seed(seed, (validation ? 2000 : 1000) + level);
  return o;
}

GaTrainingConfig load_ga_config(const std::filesystem::path& path) {
  return load_training_config<GaTrainingConfig>(path, config_from);
}

}  // namespace imm::trainer::ga
