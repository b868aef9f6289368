// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/ga/tuned_levels.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "imm/support/bounded_search.hpp"
#include "imm/trainer/baseline_tuning.hpp"
#include "imm/trainer/regime_checks.hpp"

namespace imm::trainer::ga {
namespace {

int total_rules(const GaFuzzyImmSpec& spec) {
  int rules = 0;
  for (const FuzzyLevel& level : spec.levels) rules += static_cast<int>(level.table.size());
  return rules;
}

// ζ_p + ζ_v scoring with the config's λ and σ_z.
ProblemOptions zeta_options(const GaTrainingConfig& config) {
  ProblemOptions options = config.problem_options(0);
  options.error = ErrorKind::kZeta;
  return options;
}

}  // namespace

GaTrainingConfig resolve_levels(GaTrainingConfig config, const TrainingSet& training) {
  if (!config.tuned_levels || config.baseline) return config;
  AxisCvImmSpec base;
  base.settings = config.filter;
  const Tuned<AxisCvImmSpec> tuned =
      tune_axis_cv_imm(base, {training}, acceleration_scale(config.regime), config.level_count,
                       TransitionTuning::kJointly);
  std::vector<double> q = tuned.spec.process_noise;
  std::sort(q.begin(), q.end());
  config.baseline =
      TunedBaseline{q, tuned.spec.settings.transition_stay, tuned.score, tuned.evaluations};
  config.filter.transition_stay = tuned.spec.settings.transition_stay;
  config.levels.clear();
  for (double qj : q) config.levels.push_back(std::sqrt(qj));
  config.validate();
  return config;
}

GaFuzzyImmSpec tuned_baseline_spec(const GaTrainingConfig& config) {
  if (!config.baseline) throw std::invalid_argument("tuned_baseline_spec needs resolved levels");
  const ProblemOptions options = config.problem_options(0);
  const double spread = options.sigma_max * options.error_scale;
  GaFuzzyImmSpec spec;
  spec.settings = config.filter;
  spec.settings.transition_stay = config.baseline->transition_stay;
  for (double q : config.baseline->process_noise) {
    char name[32];
    std::snprintf(name, sizeof name, "u%g", std::sqrt(q));
    spec.levels.push_back({name, std::sqrt(q), FuzzyRuleTable({{0.0, spread, 0.0, spread, q}})});
  }
  return spec;
}

LevelRefinement refine_levels(GaFuzzyImmSpec& spec, const GaTrainingConfig& config,
                              const TrainingSet& training) {
  const ProblemOptions options = zeta_options(config);
  const int rules = total_rules(spec);
  const std::size_t n = spec.levels.size();
  auto spec_at = [&](const std::vector<double>& x) {
    GaFuzzyImmSpec scaled = spec;
    for (std::size_t j = 0; j < n; ++j) {
      std::vector<FuzzyRule> rules_j = scaled.levels[j].table.rules();
      for (FuzzyRule& rule : rules_j) rule.w *= std::pow(10.0, x[j]);
      scaled.levels[j].table = FuzzyRuleTable(std::move(rules_j));
      if (config.tuned_levels) scaled.levels[j].maneuver_level *= std::pow(10.0, 0.5 * x[j]);
    }
    scaled.settings.transition_stay = 1.0 - std::pow(10.0, x.back());
    return scaled;
  };
  std::vector<double> x0(n, 0.0), lower(n, -1.0), upper(n, 1.0);
  x0.push_back(
      std::clamp(std::log10(1.0 - spec.settings.transition_stay), kLogLeaveLow, kLogLeaveHigh));
  lower.push_back(kLogLeaveLow);
  upper.push_back(kLogLeaveHigh);
  LevelRefinement refinement;
  refinement.before = evaluate_imm(spec, training, options, rules);
  const support::SearchResult found = support::subplex(
      [&](const std::vector<double>& x) {
        return evaluate_imm(spec_at(x), training, options, rules).error;
      },
      x0, lower, upper, std::max(config.memetic.max_evaluations, 50), 1e-4);
  refinement.evaluations = found.evaluations;
  GaFuzzyImmSpec refined = spec_at(found.x);
  refinement.after = evaluate_imm(refined, training, options, rules);
  refinement.accepted = refinement.after.error < refinement.before.error;
  if (!refinement.accepted) {
    refinement.after = refinement.before;
    refinement.factors.assign(n, 1.0);
    refinement.transition_stay = spec.settings.transition_stay;
    return refinement;
  }
  for (std::size_t j = 0; j < n; ++j) refinement.factors.push_back(std::pow(10.0, found.x[j]));
  refinement.transition_stay = refined.settings.transition_stay;
  spec = std::move(refined);
  return refinement;
}

BaselineCheck check_against_baseline(GaFuzzyImmSpec& spec, const GaTrainingConfig& config,
                                     const TrainingSet& validation) {
  const ProblemOptions options = zeta_options(config);
  GaFuzzyImmSpec baseline = tuned_baseline_spec(config);
  BaselineCheck check;
  check.learned = evaluate_imm(spec, validation, options, total_rules(spec));
  check.baseline = evaluate_imm(baseline, validation, options, total_rules(baseline));
  check.learned_part_on = check.learned.error < check.baseline.error;
  if (validation.plots_only) {
    auto rms = [&](const GaFuzzyImmSpec& s) {
      return axis_innovation_rms(
          [&s] { return std::make_unique<ImmAxisFilter>(build_ga_fuzzy_axis_imm(s)); },
          {validation});
    };
    check.learned_innovation_rms = rms(spec);
    check.baseline_innovation_rms = rms(baseline);
    check.learned_part_on =
        check.learned_part_on && check.learned_innovation_rms <= check.baseline_innovation_rms;
  }
  if (!check.learned_part_on) spec = std::move(baseline);
  return check;
}

std::optional<std::string> unreachable_quiet_level(const GaTrainingConfig& config,
                                                   const TrainingSet& training) {
  if (config.tuned_levels || config.levels.empty()) return std::nullopt;
  const auto quietest = std::min_element(config.levels.begin(), config.levels.end());
  const ProblemOptions options =
      config.problem_options(static_cast<std::size_t>(quietest - config.levels.begin()));
  const double floor_sqrt =
      options.consequent_low * (options.maneuver_level + options.process_noise_sigma);
  const double reachable = floor_sqrt * floor_sqrt;
  AxisCvImmSpec base;
  base.settings = config.filter;
  const Tuned<AxisCvImmSpec> tuned =
      tune_axis_cv_imm(base, {training}, acceleration_scale(config.regime),
                       static_cast<int>(config.levels.size()), TransitionTuning::kFixed);
  const double quiet =
      *std::min_element(tuned.spec.process_noise.begin(), tuned.spec.process_noise.end());
  if (!(reachable > 10.0 * quiet)) return std::nullopt;
  char text[512];
  std::snprintf(
      text, sizeof text,
      "the quietest level (a_M %g) cannot go below q = %.3g (consequent floor %g x (a_M + "
      "sqrt q)), %.0f times the lowest q of the constant-q IMM tuned on the training "
      "split (%.3g): on straight segments the model cannot be as quiet as that IMM; use "
      "levels = \"tuned\" (configs/ga_fuzzy_imm_tuned.toml) or quieter levels",
      *quietest, reachable, options.consequent_low, reachable / quiet, quiet);
  return std::string(text);
}

}  // namespace imm::trainer::ga
