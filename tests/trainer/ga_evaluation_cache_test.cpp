// SPDX-License-Identifier: Apache-2.0
// The GA's evaluation cache: the same populations and evaluations as evaluating every genome, with
// fewer evaluations.
#include <gtest/gtest.h>

#include <atomic>

#include "imm/trainer/ga/genetic_algorithm.hpp"
#include "testing/ga_training_sets.hpp"

namespace imm::trainer::ga {
namespace {

// Forwards to a problem, counting the evaluations; `keyed` false hides the phenotype keys (every
// genome is evaluated).
class Counting final : public GenomeProblem {
 public:
  Counting(const GenomeProblem& inner, bool keyed) : inner_(inner), keyed_(keyed) {}
  [[nodiscard]] int max_rules() const override { return inner_.max_rules(); }
  [[nodiscard]] const std::vector<double>& lower() const override { return inner_.lower(); }
  [[nodiscard]] const std::vector<double>& upper() const override { return inner_.upper(); }
  [[nodiscard]] Evaluation evaluate(const Genome& genome) const override {
    ++count_;
    return inner_.evaluate(genome);
  }
  bool phenotype(const Genome& genome, std::vector<double>& key) const override {
    return keyed_ && inner_.phenotype(genome, key);
  }
  [[nodiscard]] long count() const { return count_; }

 private:
  const GenomeProblem& inner_;
  bool keyed_;
  mutable std::atomic<long> count_{0};
};

TEST(GaEvaluationCache, GivesTheUncachedPopulationsWithFewerEvaluations) {
  ProblemOptions options;
  options.fitness = FitnessKind::kSingleFilter;
  options.max_rules = 6;
  const FuzzyTableProblem problem(testing::ga_training_set(40, 2, 1), options);
  const Counting cached(problem, true), uncached(problem, false);
  GaOptions ga;
  ga.population = 40;
  ga.mutation_rate = 0.05;
  const GeneticAlgorithm with(cached, ga, 5), without(uncached, ga, 5);
  Population a = with.initialize(), b = without.initialize();
  for (int generation = 1; generation <= 12; ++generation) {
    with.evolve(a);
    without.evolve(b);
    for (std::size_t i = 0; i < a.genomes.size(); ++i) {
      ASSERT_EQ(a.genomes[i].genes, b.genomes[i].genes) << "generation " << generation;
      ASSERT_EQ(a.genomes[i].active, b.genomes[i].active);
      ASSERT_EQ(a.evaluations[i].fitness, b.evaluations[i].fitness);
      ASSERT_EQ(a.evaluations[i].error, b.evaluations[i].error);
      ASSERT_EQ(a.evaluations[i].rules, b.evaluations[i].rules);
    }
  }
  EXPECT_EQ(uncached.count(), 40 + 12 * (40 - ga.elite));
  EXPECT_LT(cached.count(), uncached.count());
  RecordProperty("evaluations_saved", static_cast<int>(uncached.count() - cached.count()));
}

}  // namespace
}  // namespace imm::trainer::ga
