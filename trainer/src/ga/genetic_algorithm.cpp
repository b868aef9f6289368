#include "imm/trainer/ga/genetic_algorithm.hpp"

#include <algorithm>
#include <numeric>
#include <stdexcept>

#include "imm/trainer/parallel_for.hpp"

namespace imm::trainer::ga {

std::size_t Population::best_index() const {
  std::size_t best = 0;
  for (std::size_t i = 1; i < evaluations.size(); ++i) {
    if (evaluations[i].fitness > evaluations[best].fitness) best = i;
  }
  return best;
}

double Population::mean_fitness() const {
  double sum = 0.0;
  for (const auto& e : evaluations) sum += e.fitness;
  return evaluations.empty() ? 0.0 : sum / static_cast<double>(evaluations.size());
}

GeneticAlgorithm::GeneticAlgorithm(const GenomeProblem& problem, const GaOptions& options,
                                   std::uint64_t seed)
    : problem_(problem), options_(options), seed_(seed) {
  if (options_.population < 2) throw std::invalid_argument("population must be at least 2");
  if (options_.generations < 0) throw std::invalid_argument("generations must be non-negative");
  if (options_.elite < 0 || options_.elite >= options_.population) {
    throw std::invalid_argument("elite must be in [0, population)");
  }
  if (options_.tournament_size < 1) throw std::invalid_argument("tournament_size must be ≥ 1");
  if (problem_.max_rules() < 1 ||
      problem_.lower().size() != static_cast<std::size_t>(problem_.max_rules()) * kGenesPerRule ||
      problem_.upper().size() != problem_.lower().size()) {
    throw std::invalid_argument("problem bounds do not match its rule slots");
  }
}

Genome GeneticAlgorithm::random_genome(datasets::Rng& rng) const {
  Genome genome;
  const auto& lower = problem_.lower();
  const auto& upper = problem_.upper();
  genome.genes.resize(lower.size());
  for (std::size_t i = 0; i < lower.size(); ++i) genome.genes[i] = rng.uniform(lower[i], upper[i]);
  genome.active.resize(static_cast<std::size_t>(problem_.max_rules()));
  for (auto& bit : genome.active) bit = rng.uniform() < options_.initial_rule_probability ? 1 : 0;
  repair(genome, rng);
  return genome;
}

void GeneticAlgorithm::repair(Genome& genome, datasets::Rng& rng) const {
  if (genome.rule_count() == 0) {
    genome.active[rng.below(genome.active.size())] = 1;
  }
}

Genome GeneticAlgorithm::crossover(const Genome& a, const Genome& b, datasets::Rng& rng) const {
  Genome child = a;
  for (std::size_t slot = 0; slot < a.active.size(); ++slot) {
    if (rng.uniform() < 0.5) {
      const std::size_t base = slot * kGenesPerRule;
      std::copy_n(b.genes.begin() + static_cast<std::ptrdiff_t>(base), kGenesPerRule,
                  child.genes.begin() + static_cast<std::ptrdiff_t>(base));
      child.active[slot] = b.active[slot];
    }
  }
  repair(child, rng);
  return child;
}

void GeneticAlgorithm::mutate(Genome& genome, datasets::Rng& rng) const {
  const auto& lower = problem_.lower();
  const auto& upper = problem_.upper();
  for (std::size_t i = 0; i < genome.genes.size(); ++i) {
    if (rng.uniform() >= options_.mutation_rate) continue;
    const double range = upper[i] - lower[i];
    double value = genome.genes[i] + options_.mutation_scale * range * rng.normal();
    // Reflect into [lower, upper] (twice at most for steps under a range; clamp the rest).
    for (int bounce = 0; bounce < 2; ++bounce) {
      if (value < lower[i]) value = 2.0 * lower[i] - value;
      if (value > upper[i]) value = 2.0 * upper[i] - value;
    }
    genome.genes[i] = std::clamp(value, lower[i], upper[i]);
  }
  for (auto& bit : genome.active) {
    if (rng.uniform() < options_.mutation_rate) bit = bit != 0 ? 0 : 1;
  }
  repair(genome, rng);
}

std::size_t GeneticAlgorithm::tournament(const Population& population, datasets::Rng& rng) const {
  const auto n = static_cast<std::uint64_t>(population.genomes.size());
  std::size_t best = rng.below(n);
  for (int i = 1; i < options_.tournament_size; ++i) {
    const std::size_t challenger = rng.below(n);
    const double challenger_fitness = population.evaluations[challenger].fitness;
    const double best_fitness = population.evaluations[best].fitness;
    // Ties go to the lower index, so the choice never depends on the draw order of equals.
    if (challenger_fitness > best_fitness ||
        (challenger_fitness == best_fitness && challenger < best)) {
      best = challenger;
    }
  }
  return best;
}

void GeneticAlgorithm::evaluate(Population& population) const {
  const auto n = static_cast<long>(population.genomes.size());
  population.evaluations.resize(population.genomes.size());
  // Each evaluation is a pure function of its genome: any schedule gives the same results.
  parallel_for(n, 4, [&](long i) {
    population.evaluations[static_cast<std::size_t>(i)] =
        problem_.evaluate(population.genomes[static_cast<std::size_t>(i)]);
  });
}

Population GeneticAlgorithm::initialize() const {
  datasets::Rng rng(datasets::derive_seed(seed_, 0));
  Population population;
  population.generation = 0;
  population.genomes.reserve(static_cast<std::size_t>(options_.population));
  for (int i = 0; i < options_.population; ++i) population.genomes.push_back(random_genome(rng));
  evaluate(population);
  return population;
}

void GeneticAlgorithm::evolve(Population& population) const {
  const int next_generation = population.generation + 1;
  datasets::Rng rng(datasets::derive_seed(seed_, static_cast<std::uint64_t>(next_generation)));
  const std::size_t n = population.genomes.size();

  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return population.evaluations[a].fitness > population.evaluations[b].fitness;
  });

  Population next;
  next.generation = next_generation;
  next.genomes.reserve(n);
  std::vector<Evaluation> elite_evaluations;
  for (int e = 0; e < options_.elite; ++e) {
    next.genomes.push_back(population.genomes[order[static_cast<std::size_t>(e)]]);
    elite_evaluations.push_back(population.evaluations[order[static_cast<std::size_t>(e)]]);
  }
  while (next.genomes.size() < n) {
    const Genome& a = population.genomes[tournament(population, rng)];
    const Genome& b = population.genomes[tournament(population, rng)];
    Genome child = rng.uniform() < options_.crossover_rate ? crossover(a, b, rng) : a;
    mutate(child, rng);
    next.genomes.push_back(std::move(child));
  }
  // Elites keep their evaluations; the offspring are evaluated.
  Population offspring;
  offspring.genomes.assign(next.genomes.begin() + options_.elite, next.genomes.end());
  evaluate(offspring);
  next.evaluations = std::move(elite_evaluations);
  next.evaluations.insert(next.evaluations.end(), offspring.evaluations.begin(),
                          offspring.evaluations.end());
  population = std::move(next);
}

}  // namespace imm::trainer::ga
