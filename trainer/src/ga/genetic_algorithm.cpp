// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/ga/genetic_algorithm.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>

#include "imm/core/invalid_parameter.hpp"
#include "imm/trainer/parallel_for.hpp"
#include "imm/trainer/ranks.hpp"

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

void GaOptions::validate() const {
  require(population >= 2 && population <= 100000, "population", "must be in [2, 100000]");
  require(generations >= 0 && generations <= 100000, "generations", "must be in [0, 100000]");
  require(crossover_rate >= 0.0 && crossover_rate <= 1.0, "crossover_rate", "must be in [0, 1]");
  require(mutation_rate >= 0.0 && mutation_rate <= 1.0, "mutation_rate", "must be in [0, 1]");
  require(elite >= 0 && elite < population, "elite", "must be in [0, population)");
  require(tournament_size >= 1 && tournament_size <= population, "tournament_size",
          "must be in [1, population]");
  require(initial_rule_probability > 0.0 && initial_rule_probability <= 1.0,
          "initial_rule_probability", "must be in (0, 1]");
  // (0, 1] holds no NaN or infinity.
  require(mutation_scale > 0.0 && mutation_scale <= 1.0, "mutation_scale", "must be in (0, 1]");
}

GeneticAlgorithm::GeneticAlgorithm(const GenomeProblem& problem, const GaOptions& options,
                                   std::uint64_t seed)
    : problem_(problem), options_(options), seed_(seed) {
  options_.validate();
  if (problem_.max_rules() < 1 ||
      problem_.lower().size() != static_cast<std::size_t>(problem_.max_rules()) * kGenesPerRule ||
      problem_.upper().size() != problem_.lower().size()) {
    throw std::invalid_argument("problem bounds do not match its rule slots");
  }
  log_keep_ = std::log1p(-options_.mutation_rate);
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
  Genome child;
  crossover_into(a, b, child, rng);
  return child;
}

void GeneticAlgorithm::crossover_into(const Genome& a, const Genome& b, Genome& child,
                                      datasets::Rng& rng) const {
  // Each slot is copied once, from the parent its coin names; sizes match after the first
  // generation, so nothing is allocated.
  child.genes.resize(a.genes.size());
  child.active.resize(a.active.size());
  std::uint64_t coins = 0;
  for (std::size_t slot = 0; slot < a.active.size(); ++slot) {
    if (slot % 64 == 0) coins = rng.bits();
    const Genome& parent = (coins & 1U) != 0 ? b : a;
    coins >>= 1U;
    const std::size_t base = slot * kGenesPerRule;
    std::copy_n(parent.genes.data() + base, kGenesPerRule, child.genes.data() + base);
    child.active[slot] = parent.active[slot];
  }
  repair(child, rng);
}

std::size_t GeneticAlgorithm::next_mutation(datasets::Rng& rng, std::size_t from,
                                            std::size_t end) const {
  if (from >= end || options_.mutation_rate <= 0.0) return end;
  if (options_.mutation_rate >= 1.0) return from;
  // P(gap = g) = (1 − p)^g p: the number of positions kept before the next mutated one. 1 − U is
  // in (0, 1], so the logarithm is finite; a gap past the end (or beyond any index) is the end.
  const double gap = std::floor(std::log1p(-rng.uniform()) / log_keep_);
  if (!(gap < static_cast<double>(end - from))) return end;
  return from + static_cast<std::size_t>(gap);
}

void GeneticAlgorithm::mutate(Genome& genome, datasets::Rng& rng) const {
  const auto& lower = problem_.lower();
  const auto& upper = problem_.upper();
  const std::size_t genes = genome.genes.size();
  const std::size_t end = genes + genome.active.size();
  for (std::size_t i = next_mutation(rng, 0, end); i < end; i = next_mutation(rng, i + 1, end)) {
    if (i >= genes) {
      auto& bit = genome.active[i - genes];
      bit = bit != 0 ? 0 : 1;
      continue;
    }
    const double range = upper[i] - lower[i];
    double value = genome.genes[i] + options_.mutation_scale * range * rng.normal();
    // Reflect into [lower, upper] (twice at most for steps under a range; clamp the rest).
    for (int bounce = 0; bounce < 2; ++bounce) {
      if (value < lower[i]) value = 2.0 * lower[i] - value;
      if (value > upper[i]) value = 2.0 * upper[i] - value;
    }
    genome.genes[i] = std::clamp(value, lower[i], upper[i]);
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
  population.evaluations.resize(population.genomes.size());
  evaluate_range(population, 0);
}

void GeneticAlgorithm::evaluate_range(Population& population, std::size_t first) const {
  const std::size_t size = population.genomes.size();
  // The genomes to evaluate: every one, or (with phenotype keys) the first of each key that is
  // neither cached nor earlier in this range; the others copy their source's evaluation.
  std::vector<std::size_t> todo;
  std::vector<std::pair<std::size_t, std::size_t>> copies;  // (genome, its source)
  std::unordered_map<std::string, std::size_t> first_of;    // keys evaluated now, and where
  previous_cache_.swap(cache_);
  cache_.clear();
  std::vector<double> key;
  for (std::size_t i = first; i < size; ++i) {
    if (!problem_.phenotype(population.genomes[i], key)) {
      todo.push_back(i);
      continue;
    }
    std::string bytes(reinterpret_cast<const char*>(key.data()), key.size() * sizeof(double));
    if (const auto cached = previous_cache_.find(bytes); cached != previous_cache_.end()) {
      population.evaluations[i] = cached->second;
      cache_.insert(*cached);
    } else if (const auto seen = first_of.find(bytes); seen != first_of.end()) {
      copies.emplace_back(i, seen->second);
    } else {
      first_of.emplace(std::move(bytes), i);
      todo.push_back(i);
    }
  }
  evaluate_indices(population, todo);
  for (const auto& [genome, source] : copies) {
    population.evaluations[genome] = population.evaluations[source];
  }
  for (auto& [bytes, index] : first_of) cache_.emplace(bytes, population.evaluations[index]);
}

void GeneticAlgorithm::evaluate_indices(Population& population,
                                        const std::vector<std::size_t>& todo) const {
  const auto n = static_cast<long>(todo.size());
  // Each evaluation is a pure function of its genome: any schedule gives the same results. Every
  // rank holds the same population (the same seeded draws); each evaluates its share, with OpenMP
  // inside, and the evaluations are exchanged whole.
  const Ranks& ranks = Ranks::world();
  const std::pair<long, long> share = ranks.share(n);
  const long begin = share.first;
  const long end = share.second;
  parallel_for(end - begin, 4, [&](long i) {
    const std::size_t index = todo[static_cast<std::size_t>(begin + i)];
    population.evaluations[index] = problem_.evaluate(population.genomes[index]);
  });
  if (ranks.size() == 1) return;
  constexpr int kWidth = 5;
  std::vector<double> mine;
  mine.reserve(static_cast<std::size_t>((end - begin) * kWidth));
  for (long i = begin; i < end; ++i) {
    const Evaluation& e = population.evaluations[todo[static_cast<std::size_t>(i)]];
    mine.insert(mine.end(), {e.fitness, e.error, e.position_error, e.velocity_error,
                             static_cast<double>(e.rules)});
  }
  const std::vector<double> all = ranks.gather_all(mine, n, kWidth);
  for (long i = 0; i < n; ++i) {
    const double* row = all.data() + i * kWidth;
    population.evaluations[todo[static_cast<std::size_t>(i)]] = {row[0], row[1], row[2], row[3],
                                                                 static_cast<int>(row[4])};
  }
}

Population GeneticAlgorithm::initialize(std::span<const Genome> seeds) const {
  if (seeds.size() > static_cast<std::size_t>(options_.population)) {
    throw std::invalid_argument("more seed genomes than the population holds");
  }
  datasets::Rng rng(datasets::derive_seed(seed_, 0));
  Population population;
  population.generation = 0;
  population.genomes.reserve(static_cast<std::size_t>(options_.population));
  for (int i = 0; i < options_.population; ++i) population.genomes.push_back(random_genome(rng));
  const std::vector<double>& lower = problem_.lower();
  const std::vector<double>& upper = problem_.upper();
  for (std::size_t s = 0; s < seeds.size(); ++s) {
    const Genome& seed = seeds[s];
    bool inside = seed.genes.size() == lower.size() &&
                  seed.active.size() == static_cast<std::size_t>(problem_.max_rules()) &&
                  seed.rule_count() > 0;
    for (std::size_t g = 0; inside && g < seed.genes.size(); ++g) {
      inside = seed.genes[g] >= lower[g] && seed.genes[g] <= upper[g];
    }
    if (!inside) {
      throw std::invalid_argument("seed genome " + std::to_string(s) +
                                  " does not fit the problem (size, bounds or no active rule)");
    }
    population.genomes[s] = seed;
  }
  evaluate(population);
  return population;
}

void GeneticAlgorithm::evolve(Population& population) const {
  const int next_generation = population.generation + 1;
  datasets::Rng rng(datasets::derive_seed(seed_, static_cast<std::uint64_t>(next_generation)));
  const std::size_t n = population.genomes.size();
  const auto elite = static_cast<std::size_t>(options_.elite);

  // The next generation is built in the spare population, whose genomes keep their storage from
  // the generation before: after the first call nothing is allocated here.
  Population& next = spare_;
  next.generation = next_generation;
  next.genomes.resize(n);
  next.evaluations.resize(n);
  // Elites: the `elite` fittest, ties to the lower index (the first entries of a stable sort by
  // descending fitness), found by selection.
  elite_.clear();
  for (std::size_t e = 0; e < elite; ++e) {
    std::size_t best = n;
    for (std::size_t i = 0; i < n; ++i) {
      if (std::find(elite_.begin(), elite_.end(), i) != elite_.end()) continue;
      if (best == n || population.evaluations[i].fitness > population.evaluations[best].fitness) {
        best = i;
      }
    }
    elite_.push_back(best);
    next.genomes[e].genes = population.genomes[best].genes;
    next.genomes[e].active = population.genomes[best].active;
    next.evaluations[e] = population.evaluations[best];
  }
  for (std::size_t i = elite; i < n; ++i) {
    const Genome& a = population.genomes[tournament(population, rng)];
    const Genome& b = population.genomes[tournament(population, rng)];
    Genome& child = next.genomes[i];
    if (rng.uniform() < options_.crossover_rate) {
      crossover_into(a, b, child, rng);
    } else {
      child.genes = a.genes;
      child.active = a.active;
    }
    mutate(child, rng);
  }
  // Elites keep their evaluations; the offspring are evaluated.
  evaluate_range(next, elite);
  std::swap(population, next);
}

}  // namespace imm::trainer::ga
