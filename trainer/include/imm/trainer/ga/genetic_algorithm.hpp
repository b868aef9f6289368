// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The genetic algorithm of seed 000 §3.1 (Table 1: population 500, 100 generations, crossover
/// 0.9, mutation 0.01), for the mixed real/binary genome of fuzzy_table_problem.hpp.
///
/// Operators, and why:
/// - Selection: k-tournament (default k = 2). It needs only the order of fitness values, so the
///   selection pressure does not depend on how eq. (16) scales fitness, and it is cheap.
/// - Crossover (rate p_c): slot-uniform — each rule slot (its five reals and its bit) comes whole
///   from one parent or the other. A rule is a building block: mixing the center of one rule
///   with the spread of another destroys what both parents learned, whereas exchanging whole
///   rules recombines working rules and lets the rule count vary through the bits. One 64-bit draw
///   decides 64 slots (a bit per slot), not one uniform per slot.
/// - Mutation (rate p_m per gene): a real gene moves by a Gaussian step of a fixed fraction of its
///   range and is reflected into its bounds (every gene stays in range, no mass piles up on the
///   bounds); a bit flips. A genome that lost every rule gets one random slot back, so the rule
///   count stays in 1 … max_rules. The mutated positions (genes, then bits) are found by geometric
///   skipping: the gap to the next one is ⌊log U / log(1 − p_m)⌋, which mutates each position
///   independently with probability p_m, as a draw per position would, with one draw per
///   mutation instead of one per position (2.5 instead of 300 for Table 1's genome).
/// - Elitism: the best individuals pass unchanged, so the best fitness never decreases.
///
/// Memory: evolve() builds the next generation in a spare population whose genomes keep their
/// storage, so after the first generation a generation allocates nothing.
///
/// Evaluation cache: for a problem with a phenotype key (GenomeProblem::phenotype), a genome whose
/// key was evaluated in this generation or the one before takes that evaluation instead of being
/// evaluated again — the same result, since an evaluation is a pure function of the key (about a
/// quarter of the default GA training's genomes repeat an earlier table).
///
/// Determinism: every random draw is made serially from a stream seeded by (seed, generation);
/// only the fitness evaluations, which draw nothing, run in parallel (OpenMP). The result is
/// bit-identical for a seed whatever the thread count, and a run resumed from the population of
/// generation g continues exactly as the uninterrupted run.

#include <cstdint>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "imm/datasets/random.hpp"
#include "imm/trainer/ga/fuzzy_table_problem.hpp"

namespace imm::trainer::ga {

struct GaOptions {
  int population = 500;
  int generations = 100;
  double crossover_rate = 0.9;
  double mutation_rate = 0.01;
  int elite = 2;
  int tournament_size = 2;
  double initial_rule_probability = 0.5;  ///< P(slot active) in the initial population
  double mutation_scale = 0.1;            ///< Gaussian step, fraction of the gene's range

  /// Throws InvalidParameter naming the option as a GA config's [ga] table spells it
  /// ("population", "elite", …). The config's loader and the GeneticAlgorithm both call it.
  void validate() const;
};

struct Population {
  int generation = 0;  ///< generations completed (0: the evaluated initial population)
  std::vector<Genome> genomes;
  std::vector<Evaluation> evaluations;

  [[nodiscard]] std::size_t best_index() const;  ///< highest fitness, lowest index on ties
  [[nodiscard]] double mean_fitness() const;
};

class GeneticAlgorithm {
 public:
  /// Throws std::invalid_argument for inconsistent options.
  GeneticAlgorithm(const GenomeProblem& problem, const GaOptions& options, std::uint64_t seed);

  /// The random, evaluated initial population (generation 0); `seeds` (at most the population)
  /// replace its first genomes after every random one was drawn, so the random rest is the same
  /// with or without them. A seed outside the problem's bounds or of the wrong size is refused.
  [[nodiscard]] Population initialize(std::span<const Genome> seeds = {}) const;
  /// Replaces `population` by the next generation, evaluated.
  void evolve(Population& population) const;

  // The operators, public for tests.
  [[nodiscard]] Genome random_genome(datasets::Rng& rng) const;
  [[nodiscard]] Genome crossover(const Genome& a, const Genome& b, datasets::Rng& rng) const;
  /// crossover() into existing storage (the same draws).
  void crossover_into(const Genome& a, const Genome& b, Genome& child, datasets::Rng& rng) const;
  void mutate(Genome& genome, datasets::Rng& rng) const;
  [[nodiscard]] std::size_t tournament(const Population& population, datasets::Rng& rng) const;
  /// Evaluates every genome (in parallel when OpenMP has more than one thread).
  void evaluate(Population& population) const;

  [[nodiscard]] const GaOptions& options() const { return options_; }

 private:
  void repair(Genome& genome, datasets::Rng& rng) const;
  /// The next position ≥ `from` that mutates (geometric skipping), or `end` when none before it.
  std::size_t next_mutation(datasets::Rng& rng, std::size_t from, std::size_t end) const;
  void evaluate_range(Population& population, std::size_t first) const;
  // Evaluates the genomes at `todo` (over the ranks and threads) and exchanges the results.
  void evaluate_indices(Population& population, const std::vector<std::size_t>& todo) const;

  const GenomeProblem& problem_;
  GaOptions options_;
  std::uint64_t seed_;
  double log_keep_ = 0.0;  ///< log(1 − p_m), < 0 for 0 < p_m < 1
  // evolve()'s workspace: the population the next generation is built in (swapped with the
  // caller's), and the elite indices. One GeneticAlgorithm evolves one population at a time.
  mutable Population spare_;
  mutable std::vector<std::size_t> elite_;
  // The evaluation cache: phenotype keys (their bytes) of this generation and the one before.
  mutable std::unordered_map<std::string, Evaluation> cache_, previous_cache_;
};

}  // namespace imm::trainer::ga
