// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/ga/memetic.hpp"

#include <nlopt.hpp>

namespace imm::trainer::ga {

MemeticResult polish(const FuzzyTableProblem& problem, const Genome& genome,
                     const MemeticOptions& options) {
  MemeticResult result;
  result.genome = genome;
  result.before = problem.evaluate(genome);
  result.after = result.before;
  if (!options.enabled || options.max_evaluations <= 0) return result;

  // The active slots' genes are the variables.
  std::vector<std::size_t> index;
  for (std::size_t slot = 0; slot < genome.active.size(); ++slot) {
    if (genome.active[slot] == 0) continue;
    for (int g = 0; g < kGenesPerRule; ++g)
      index.push_back(slot * kGenesPerRule + static_cast<std::size_t>(g));
  }
  std::vector<double> x(index.size()), lower(index.size()), upper(index.size());
  for (std::size_t i = 0; i < index.size(); ++i) {
    x[i] = genome.genes[index[i]];
    lower[i] = problem.lower()[index[i]];
    upper[i] = problem.upper()[index[i]];
  }

  struct Context {
    const FuzzyTableProblem* problem = nullptr;
    Genome candidate;
    const std::vector<std::size_t>* index = nullptr;
    int evaluations = 0;
  } context{&problem, genome, &index, 0};

  nlopt::opt optimizer(nlopt::LN_BOBYQA, static_cast<unsigned>(x.size()));
  optimizer.set_lower_bounds(lower);
  optimizer.set_upper_bounds(upper);
  optimizer.set_maxeval(options.max_evaluations);
  optimizer.set_xtol_rel(options.relative_tolerance);
  optimizer.set_min_objective(
      [](const std::vector<double>& v, std::vector<double>& /*grad*/, void* data) -> double {
        auto& c = *static_cast<Context*>(data);
        for (std::size_t i = 0; i < v.size(); ++i) c.candidate.genes[(*c.index)[i]] = v[i];
        ++c.evaluations;
        return -c.problem->evaluate(c.candidate).fitness;
      },
      &context);
  double best = 0.0;
  try {
    optimizer.optimize(x, best);
  } catch (const std::exception&) {
    // Roundoff or forced stop: x holds the best point NLopt reached.
  }
  Genome polished = genome;
  for (std::size_t i = 0; i < index.size(); ++i) polished.genes[index[i]] = x[i];
  const Evaluation after = problem.evaluate(polished);
  result.evaluations = context.evaluations;
  if (after.fitness > result.before.fitness) {
    result.genome = std::move(polished);
    result.after = after;
  }
  return result;
}

}  // namespace imm::trainer::ga
