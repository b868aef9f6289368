// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/ga/ga_config.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/datasets/random.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/regime_checks.hpp"
#include "imm/trainer/training_config.hpp"

namespace imm::trainer::ga {
namespace {

bool finite_positive(double x) { return std::isfinite(x) && x > 0.0; }

// The config's own keys (config_on has read its regime and seed).
void fill(const support::ConfigTable& root, GaTrainingConfig& c) {
  c.filter.sample_period = c.regime.sample_period;
  c.filter.measurement_sigma = c.regime.sensor.noise.sigma(0);
  if (const auto f = root.table("filter")) {
    c.filter.transition_stay = f->real_or("transition_stay", c.filter.transition_stay);
    c.filter.initial_first_probability =
        f->real_or("initial_first_probability", c.filter.initial_first_probability);
  }
  bool automatic = true;
  if (const auto t = root.table("training")) {
    c.level_count = t->count_or("level_count", c.level_count);
    c.refine_levels = t->boolean_or("refine_levels", c.refine_levels);
    if (t->has("error")) {
      const std::string error = t->text("error");
      if (error == "equation17") {
        c.fuzzy.error = ErrorKind::kEquation17;
      } else if (error == "zeta") {
        c.fuzzy.error = ErrorKind::kZeta;
      } else {
        t->fail("error", "unknown error '" + error + "' (expected equation17 or zeta)");
      }
    }
    if (t->is_array("levels")) {
      const Eigen::VectorXd levels = t->reals("levels");
      c.levels.assign(levels.data(), levels.data() + levels.size());
      automatic = false;
    } else if (t->has("levels") && t->text("levels") == "tuned") {
      c.tuned_levels = true;
      automatic = false;
    } else if (t->has("levels") && t->text("levels") != "auto") {
      t->fail("levels", "expected \"auto\", \"tuned\" or a list of accelerations");
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
  }
  require(c.level_count >= 1 && c.level_count <= 8, "training.level_count", "must be in [1, 8]");
  if (automatic) c.levels = automatic_levels(c.regime, c.level_count);
  if (const auto f = root.table("fuzzy")) {
    if (f->has("antecedents")) {
      c.fuzzy.antecedents = fuzzy_antecedents_from(f->text("antecedents"), f->path("antecedents"));
    }
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
}

}  // namespace

std::vector<double> automatic_levels(const datasets::Regime& regime, int count) {
  const double high = regime.max_acceleration();
  const double low = std::max(regime.min_acceleration(), 1e-3 * high);
  require(high > 0.0, "training.levels",
          "regime '" + regime.name + "' commands no acceleration: give the levels");
  std::vector<double> levels;
  for (int i = 0; i < count; ++i) {
    const double f = count == 1 ? 1.0 : static_cast<double>(i) / (count - 1);
    levels.push_back(low * std::pow(high / low, f));
  }
  return levels;
}

ProblemOptions GaTrainingConfig::problem_options(std::size_t level) const {
  ProblemOptions o = fuzzy;
  o.maneuver_level = levels[level];
  o.process_noise_sigma = tuned_levels ? 0.0 : regime.process_noise_sigma;
  o.error_scale = filter.measurement_sigma;
  return o;
}

void GaTrainingConfig::validate() const {
  require_per_axis_sensor(regime, "the GA-fuzzy IMM");
  validate_within("filter.", filter);
  require((tuned_levels && !baseline) || (!levels.empty() && levels.size() <= 8), "training.levels",
          "need 1 to 8 levels");
  require(fuzzy.error == ErrorKind::kEquation17 || fuzzy.fitness == FitnessKind::kImm,
          "training.error", "ζ_p + ζ_v needs the IMM fitness (\"imm\")");
  if (tuned_levels) {
    require(fuzzy.fitness == FitnessKind::kImm, "training.fitness",
            "tuned levels need the IMM fitness (\"imm\")");
    require(fuzzy.consequent_low <= 1.0 && fuzzy.consequent_high >= 1.0, "fuzzy.consequent_range",
            "must contain 1 with tuned levels (the tuned IMM's own q_j)");
  }
  for (double u : levels) limits::require_in(u, limits::kAcceleration, "training.levels");
  require(fuzzy.max_rules >= 1 && fuzzy.max_rules <= 50, "fuzzy.max_rules", "must be in [1, 50]");
  require(fuzzy.sigma_min > 0.0 && fuzzy.sigma_max > fuzzy.sigma_min && fuzzy.sigma_max <= 1e6,
          "fuzzy.sigma_range", "must be [min, max] with 0 < min < max ≤ 10⁶ (× the plot σ)");
  // √w in units of a_M + √q (eq. 15): a table's variances then stay within (1000 a_M)².
  require(std::isfinite(fuzzy.consequent_low) && fuzzy.consequent_low >= 0.0 &&
              fuzzy.consequent_high > fuzzy.consequent_low && fuzzy.consequent_high <= 1000.0,
          "fuzzy.consequent_range", "must be [low, high] with 0 ≤ low < high ≤ 1000");
  require(fuzzy.lambda >= 0.0 && fuzzy.lambda <= 1.0, "ga.lambda", "must be in [0, 1]");
  validate_within("ga.", ga);
  require(memetic.max_evaluations >= 0, "memetic.max_evaluations", "must be non-negative");
  require(finite_positive(max_validation_error), "gate.max_validation_error", "must be positive");
  require(memetic.max_evaluations <= 1000000, "memetic.max_evaluations", "must be at most 10⁶");
}

GaTrainingConfig load_ga_config(const std::filesystem::path& path,
                                const std::optional<std::filesystem::path>& regime) {
  return load_training_config<GaTrainingConfig>(path, fill, regime);
}

}  // namespace imm::trainer::ga
