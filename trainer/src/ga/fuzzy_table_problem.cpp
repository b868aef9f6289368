// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/ga/fuzzy_table_problem.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "imm/filters/fuzzy_noise_filter.hpp"
#include "imm/trainer/baseline_tuning.hpp"

namespace imm::trainer::ga {
namespace {

// Two-point start from scans 0 and 1 (as the tracker does).
GaussianState<2> two_point(const AxisTrajectory& t, double T, double r) {
  GaussianState<2> state;
  state.mean << t.measurement(1), (t.measurement(1) - t.measurement(0)) / T;
  state.covariance << r, r / T, r / T, 2.0 * r / (T * T);
  return state;
}

// Eq. (16); a failed run (infinite error) has fitness 0.
double fitness_of(const ProblemOptions& options, double error, int rules) {
  return std::isfinite(error)
             ? options.lambda / (error + 1.0) + (1.0 - options.lambda) / (rules + 1.0)
             : 0.0;
}

// Eq. (16)-(17) from the error sums.
Evaluation score(const ProblemOptions& options, double position_sum, double velocity_sum,
                 long count, bool failed, int rules) {
  Evaluation e;
  e.rules = rules;
  if (failed || count == 0) {
    e.error = std::numeric_limits<double>::infinity();
    e.fitness = 0.0;
    return e;
  }
  e.position_error = position_sum / static_cast<double>(count);
  e.velocity_error = velocity_sum / static_cast<double>(count);
  e.error = std::hypot(e.position_error, e.velocity_error) / options.error_scale;
  e.fitness = fitness_of(options, e.error, e.rules);
  return e;
}

// Eq. (16) from a batched run: ζ_p + ζ_v (kZeta; without truth the predictive NLL per plot, as
// axis_zetas) or eq. (17)'s sums.
Evaluation score(const ProblemOptions& options, const ImmRunErrors& run, int rules, bool plots_only,
                 double nll_floor) {
  if (options.error == ErrorKind::kEquation17) {
    return score(options, run.position_abs_sum, run.velocity_abs_sum, run.count, run.failed, rules);
  }
  Evaluation e;
  e.rules = rules;
  e.position_error = plots_only ? run.predictive_nll - nll_floor : run.zeta_p;
  e.velocity_error = plots_only ? 0.0 : run.zeta_v;
  if (run.failed) e.position_error = e.velocity_error = std::numeric_limits<double>::infinity();
  e.error = e.position_error + e.velocity_error;
  e.fitness = fitness_of(options, e.error, e.rules);
  return e;
}

}  // namespace

int Genome::rule_count() const {
  int count = 0;
  for (std::uint8_t bit : active) count += bit != 0 ? 1 : 0;
  return count;
}

std::string_view to_string(FitnessKind kind) {
  return kind == FitnessKind::kSingleFilter ? "single" : "imm";
}

std::string_view to_string(ErrorKind kind) {
  return kind == ErrorKind::kEquation17 ? "equation17" : "zeta";
}

FuzzyTableProblem::FuzzyTableProblem(TrainingSet training, const ProblemOptions& options,
                                     ImmContext context)
    : training_(std::move(training)), options_(options), context_(std::move(context)) {
  if (options_.fitness == FitnessKind::kImm && context_.slot >= context_.levels.size()) {
    throw std::invalid_argument("IMM fitness needs the levels and the candidate's slot");
  }
  if (options_.max_rules < 1 || options_.max_rules > static_cast<int>(FuzzyRuleTable::kMaxRules)) {
    throw std::invalid_argument("max_rules must be in [1, 50]");
  }
  for (const auto& t : training_.trajectories) {
    if (t.measurement.size() < 3) throw std::invalid_argument("training trajectories need 3 scans");
  }
  const double s = options_.maneuver_level + options_.process_noise_sigma;
  // Observed residual ranges under a constant q = s² (one rule at the top of eq. 15).
  const FuzzyNoiseFilter reference(FuzzyRuleTable({{0.0, 1.0, 0.0, 1.0, s * s}}),
                                   training_.sample_period, training_.measurement_variance,
                                   options_.antecedents);
  double r_min = std::numeric_limits<double>::infinity(), r_max = -r_min;
  double dr_min = r_min, dr_max = -r_min;
  for (const auto& t : training_.trajectories) {
    GaussianState<2> state = two_point(t, training_.sample_period, training_.measurement_variance);
    double previous = 0.0;
    for (Eigen::Index k = 2; k < t.measurement.size(); ++k) {
      const auto step = reference.step(state, previous, t.measurement(k));
      if (k > 2) {
        dr_min = std::min(dr_min, step.antecedent - previous);
        dr_max = std::max(dr_max, step.antecedent - previous);
      }
      r_min = std::min(r_min, step.antecedent);
      r_max = std::max(r_max, step.antecedent);
      previous = step.antecedent;
    }
  }
  ranges_ = {r_min, r_max, dr_min, dr_max};
  // Whether the batch runs this IMM depends only on the settings and the level count: decided
  // once, for every genome.
  if (options_.fitness == FitnessKind::kImm && options_.batched &&
      ImmFitnessBatch::supports(imm_with(context_.levels[context_.slot].table))) {
    batch_ = std::make_shared<const ImmFitnessBatch>(training_);
  }
  lower_.resize(static_cast<std::size_t>(gene_count()));
  upper_.resize(lower_.size());
  for (int l = 0; l < options_.max_rules; ++l) {
    const auto base = static_cast<std::size_t>(l) * kGenesPerRule;
    lower_[base + 0] = r_min, upper_[base + 0] = r_max;
    const double sigma_min = options_.sigma_min * options_.input_scale();
    const double sigma_max = options_.sigma_max * options_.input_scale();
    lower_[base + 1] = sigma_min, upper_[base + 1] = sigma_max;
    lower_[base + 2] = dr_min, upper_[base + 2] = dr_max;
    lower_[base + 3] = sigma_min, upper_[base + 3] = sigma_max;
    lower_[base + 4] = options_.consequent_low * s, upper_[base + 4] = options_.consequent_high * s;
  }
}

FuzzyRuleTable FuzzyTableProblem::decode(const Genome& genome) const {
  std::vector<FuzzyRule> rules;
  for (int l = 0; l < options_.max_rules; ++l) {
    if (genome.active[static_cast<std::size_t>(l)] == 0) continue;
    const double* g = genome.genes.data() + static_cast<std::ptrdiff_t>(l) * kGenesPerRule;
    rules.push_back({g[0], g[1], g[2], g[3], g[4] * g[4]});
  }
  return FuzzyRuleTable(std::move(rules));
}

bool FuzzyTableProblem::phenotype(const Genome& genome, std::vector<double>& key) const {
  key.clear();
  for (int l = 0; l < options_.max_rules; ++l) {
    if (genome.active[static_cast<std::size_t>(l)] == 0) continue;
    const auto begin = genome.genes.begin() + static_cast<std::ptrdiff_t>(l) * kGenesPerRule;
    key.insert(key.end(), begin, begin + kGenesPerRule);
  }
  return true;
}

Genome FuzzyTableProblem::constant_genome(double sqrt_w) const {
  Genome genome;
  genome.genes.resize(lower_.size());
  for (std::size_t g = 0; g < lower_.size(); ++g) genome.genes[g] = 0.5 * (lower_[g] + upper_[g]);
  genome.active.assign(static_cast<std::size_t>(options_.max_rules), 0);
  genome.active[0] = 1;
  genome.genes[0] = std::clamp(0.0, lower_[0], upper_[0]);
  genome.genes[1] = upper_[1];
  genome.genes[2] = std::clamp(0.0, lower_[2], upper_[2]);
  genome.genes[3] = upper_[3];
  genome.genes[4] = std::clamp(sqrt_w, lower_[4], upper_[4]);
  return genome;
}

Evaluation evaluate_imm(const GaFuzzyImmSpec& spec, const TrainingSet& set,
                        const ProblemOptions& options, int rules) {
  if (options.error == ErrorKind::kZeta) {
    const AxisZetas zetas = axis_zetas(
        [&spec] { return std::make_unique<ImmAxisFilter>(build_ga_fuzzy_axis_imm(spec)); }, {set});
    Evaluation e;
    e.rules = rules;
    e.position_error = zetas.position;
    e.velocity_error = zetas.velocity;
    e.error = zetas.position + zetas.velocity;
    e.fitness = fitness_of(options, e.error, e.rules);
    return e;
  }
  double position_sum = 0.0, velocity_sum = 0.0;
  long count = 0;
  bool failed = false;
  ImmEstimator<2, 1> imm = build_ga_fuzzy_axis_imm(spec);
  for (const auto& t : set.trajectories) {
    imm.initialize(two_point(t, set.sample_period, set.measurement_variance));
    for (Eigen::Index k = 2; k < t.measurement.size() && !failed; ++k) {
      failed = imm.step(Vector<1>(t.measurement(k))) != StepStatus::kOk;
      position_sum += std::abs(t.position(k) - imm.estimate().mean(0));
      velocity_sum += std::abs(t.velocity(k) - imm.estimate().mean(1));
      ++count;
    }
  }
  return score(options, position_sum, velocity_sum, count, failed, rules);
}

Evaluation FuzzyTableProblem::evaluate_table(const FuzzyRuleTable& table,
                                             const TrainingSet& set) const {
  if (options_.fitness == FitnessKind::kImm) {
    // The candidate's own rules count (eq. 16 is per table).
    return evaluate_imm(imm_with(table), set, options_, static_cast<int>(table.size()));
  }
  double position_sum = 0.0, velocity_sum = 0.0;
  long count = 0;
  bool failed = false;
  {
    const FuzzyNoiseFilter filter(table, set.sample_period, set.measurement_variance,
                                  options_.antecedents);
    for (const auto& t : set.trajectories) {
      GaussianState<2> state = two_point(t, set.sample_period, set.measurement_variance);
      double previous = 0.0;
      for (Eigen::Index k = 2; k < t.measurement.size() && !failed; ++k) {
        const auto step = filter.step(state, previous, t.measurement(k));
        failed = step.status != StepStatus::kOk;
        previous = step.antecedent;
        position_sum += std::abs(t.position(k) - state.mean(0));
        velocity_sum += std::abs(t.velocity(k) - state.mean(1));
        ++count;
      }
    }
  }
  return score(options_, position_sum, velocity_sum, count, failed, static_cast<int>(table.size()));
}

GaFuzzyImmSpec FuzzyTableProblem::imm_with(FuzzyRuleTable table) const {
  GaFuzzyImmSpec spec;
  spec.settings = context_.settings;
  spec.antecedents = options_.antecedents;
  spec.levels = context_.levels;
  spec.levels[context_.slot].table = std::move(table);
  return spec;
}

Evaluation FuzzyTableProblem::evaluate(const Genome& genome) const {
  if (!batch_) return evaluate_table(decode(genome), training_);
  const GaFuzzyImmSpec spec = imm_with(decode(genome));
  const auto rules = static_cast<int>(spec.levels[context_.slot].table.size());
  return score(options_, batch_->run(spec), rules, training_.plots_only, training_.nll_floor());
}

}  // namespace imm::trainer::ga
