// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <tuple>

#include "imm/datasets/regime_file.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/ga/ga_config.hpp"
#include "imm/trainer/ga/ga_trainer.hpp"
#include "imm/trainer/ga/genetic_algorithm.hpp"
#include "imm/trainer/ga/memetic.hpp"
#include "imm/trainer/model_files/import_rules.hpp"
#include "testing/ga_training_sets.hpp"
#include "testing/regime_files.hpp"
#include "testing/temp_dir.hpp"

namespace imm::trainer::ga {
namespace {

TrainingSet small_training_set() { return testing::ga_training_set(60, 2, 1); }

ProblemOptions single_filter_options() {
  ProblemOptions options;
  options.fitness = FitnessKind::kSingleFilter;
  options.maneuver_level = 0.01;
  return options;
}

TEST(GeneticOperators, KeepEveryGeneInBoundsAndTheRuleCountInRange) {
  const FuzzyTableProblem problem(small_training_set(), single_filter_options());
  GaOptions options;
  options.population = 10;
  options.mutation_rate = 0.5;  // far above the default, to stress the bounds
  options.mutation_scale = 1.0;
  const GeneticAlgorithm algorithm(problem, options, 3);
  datasets::Rng rng(11);
  Genome a = algorithm.random_genome(rng), b = algorithm.random_genome(rng);
  for (int i = 0; i < 2000; ++i) {
    Genome child = algorithm.crossover(a, b, rng);
    algorithm.mutate(child, rng);
    for (std::size_t g = 0; g < child.genes.size(); ++g) {
      ASSERT_GE(child.genes[g], problem.lower()[g]);
      ASSERT_LE(child.genes[g], problem.upper()[g]);
    }
    ASSERT_GE(child.rule_count(), 1);
    ASSERT_LE(child.rule_count(), problem.max_rules());
    (i % 2 == 0 ? a : b) = std::move(child);
  }
}

// A genome problem of 80 rule slots (two 64-slot crossover words) in [0, 1]: the operators only.
class UnitBoxProblem final : public GenomeProblem {
 public:
  [[nodiscard]] int max_rules() const override { return kSlots; }
  [[nodiscard]] const std::vector<double>& lower() const override { return lower_; }
  [[nodiscard]] const std::vector<double>& upper() const override { return upper_; }
  [[nodiscard]] Evaluation evaluate(const Genome& /*genome*/) const override { return {}; }
  static constexpr int kSlots = 80;

 private:
  std::vector<double> lower_ = std::vector<double>(kSlots * kGenesPerRule, 0.0);
  std::vector<double> upper_ = std::vector<double>(kSlots * kGenesPerRule, 1.0);
};

Genome uniform_genome(double gene, std::uint8_t bit) {
  Genome genome;
  genome.genes.assign(UnitBoxProblem::kSlots * kGenesPerRule, gene);
  genome.active.assign(UnitBoxProblem::kSlots, bit);
  return genome;
}

// A small GA's options at mutation rate `rate` (the operator tests draw from it directly).
GaOptions mutation_only(double rate) {
  GaOptions options;
  options.population = 10;
  options.mutation_rate = rate;
  return options;
}

// Geometric skipping must mutate every position (each gene, then each bit) independently with
// probability p_m, as one Bernoulli draw per position does: per-position counts within 5σ of the
// binomial mean, at a low and a high rate; p_m = 0 changes nothing, p_m = 1 changes everything.
TEST(GeneticOperators, MutationHitsEveryPositionWithItsRate) {
  const UnitBoxProblem problem;
  for (const double rate : {0.01, 0.2}) {
    const GeneticAlgorithm algorithm(problem, mutation_only(rate), 3);
    datasets::Rng rng(17);
    const Genome original = uniform_genome(0.5, 1);
    const std::size_t genes = original.genes.size();
    std::vector<int> hits(genes + original.active.size(), 0);
    constexpr int kDraws = 20000;
    for (int n = 0; n < kDraws; ++n) {
      Genome genome = original;
      algorithm.mutate(genome, rng);
      for (std::size_t i = 0; i < genes; ++i) hits[i] += genome.genes[i] != 0.5 ? 1 : 0;
      for (std::size_t i = 0; i < genome.active.size(); ++i)
        hits[genes + i] += genome.active[i] == 0;
    }
    const double mean = kDraws * rate;
    const double sigma = std::sqrt(kDraws * rate * (1.0 - rate));
    long total = 0;
    for (std::size_t i = 0; i < hits.size(); ++i) {
      EXPECT_NEAR(hits[i], mean, 5.0 * sigma) << "position " << i << " at p_m " << rate;
      total += hits[i];
    }
    const double positions = static_cast<double>(hits.size());
    EXPECT_NEAR(static_cast<double>(total), positions * mean, 5.0 * sigma * std::sqrt(positions));
  }
  for (const double rate : {0.0, 1.0}) {
    const GeneticAlgorithm algorithm(problem, mutation_only(rate), 3);
    datasets::Rng rng(5);
    Genome genome = uniform_genome(0.5, 1);
    algorithm.mutate(genome, rng);
    int moved = 0;
    for (const double gene : genome.genes) moved += gene != 0.5 ? 1 : 0;
    EXPECT_EQ(moved, rate == 0.0 ? 0 : static_cast<int>(genome.genes.size()));
    // p_m = 1 flips every bit off; the repair then gives one slot back.
    EXPECT_EQ(genome.rule_count(), rate == 0.0 ? UnitBoxProblem::kSlots : 1);
  }
}

// Slot-uniform crossover from 64-bit draws: each slot comes whole (five genes and the bit) from
// one parent, from each with probability ½, independently of its neighbours, across the boundary
// of two draws too (slots 63 and 64).
TEST(GeneticOperators, CrossoverTakesEachWholeSlotFromEitherParentWithProbabilityOneHalf) {
  const UnitBoxProblem problem;
  const GeneticAlgorithm algorithm(problem, GaOptions{}, 3);
  datasets::Rng rng(23);
  const Genome a = uniform_genome(0.0, 1), b = uniform_genome(1.0, 0);
  constexpr int kDraws = 20000;
  std::vector<int> from_b(UnitBoxProblem::kSlots, 0);
  int pair_low = 0, pair_boundary = 0;
  Genome child;
  for (int n = 0; n < kDraws; ++n) {
    algorithm.crossover_into(a, b, child, rng);
    for (int slot = 0; slot < UnitBoxProblem::kSlots; ++slot) {
      const auto s = static_cast<std::size_t>(slot);
      const bool b_slot = child.genes[s * kGenesPerRule] == 1.0;
      for (int g = 1; g < kGenesPerRule; ++g) {
        ASSERT_EQ(child.genes[s * kGenesPerRule + static_cast<std::size_t>(g)], b_slot ? 1.0 : 0.0);
      }
      ASSERT_EQ(child.active[s], b_slot ? 0 : 1);
      from_b[s] += b_slot ? 1 : 0;
    }
    pair_low += child.genes[0] == 1.0 && child.genes[kGenesPerRule] == 1.0 ? 1 : 0;
    pair_boundary +=
        child.genes[63 * kGenesPerRule] == 1.0 && child.genes[64 * kGenesPerRule] == 1.0 ? 1 : 0;
  }
  const double half_sigma = std::sqrt(kDraws * 0.25);
  for (int slot = 0; slot < UnitBoxProblem::kSlots; ++slot) {
    EXPECT_NEAR(from_b[static_cast<std::size_t>(slot)], kDraws / 2.0, 5.0 * half_sigma) << slot;
  }
  const double quarter_sigma = std::sqrt(kDraws * 0.25 * 0.75);
  EXPECT_NEAR(pair_low, kDraws / 4.0, 5.0 * quarter_sigma);
  EXPECT_NEAR(pair_boundary, kDraws / 4.0, 5.0 * quarter_sigma);
}

// Eq. (15): the consequent gene is √w within [0.5, 1] (a_M + √q); centers within the observed
// residual ranges.
TEST(FuzzyTableProblem, BoundsFollowEquation15AndTheObservedResiduals) {
  const FuzzyTableProblem problem(small_training_set(), single_filter_options());
  const double s = 0.01 + 0.001;
  EXPECT_DOUBLE_EQ(problem.lower()[4], 0.5 * s);
  EXPECT_DOUBLE_EQ(problem.upper()[4], s);
  const auto ranges = problem.residual_ranges();
  EXPECT_LT(ranges[0], 0.0);
  EXPECT_GT(ranges[1], 0.0);
  EXPECT_DOUBLE_EQ(problem.lower()[0], ranges[0]);
  EXPECT_DOUBLE_EQ(problem.upper()[2], ranges[3]);
  Genome genome;
  genome.genes.assign(problem.lower().size(), 0.5);
  genome.active.assign(50, 0);
  genome.active[7] = 1;
  genome.genes[7 * 5 + 4] = 0.01;
  const FuzzyRuleTable table = problem.decode(genome);
  ASSERT_EQ(table.size(), 1u);
  EXPECT_DOUBLE_EQ(table.rules()[0].w, 1e-4);  // w = gene²
}

// Normalized antecedents: the centers span the observed ñ = r/√S̄ (a few units, whatever the
// plot σ), the spreads are dimensionless (sigma_range × 1, not × σ_z), and the trained tables'
// IMM reads them (the decoded table is the same; the config and the spec say which inputs).
TEST(FuzzyTableProblem, NormalizedAntecedentsSpanTheNormalizedInnovations) {
  ProblemOptions options = single_filter_options();
  options.antecedents = FuzzyAntecedents::kNormalizedInnovation;
  options.error_scale = 0.5;
  const FuzzyTableProblem problem(small_training_set(), options);
  const auto ranges = problem.residual_ranges();
  EXPECT_LT(ranges[0], -0.5);
  EXPECT_GT(ranges[1], 0.5);
  EXPECT_LT(std::max(-ranges[0], ranges[1]), 50.0);  // not residuals in km of a diverged filter
  EXPECT_DOUBLE_EQ(problem.lower()[1], options.sigma_min);
  EXPECT_DOUBLE_EQ(problem.upper()[3], options.sigma_max);
  const FuzzyTableProblem residual(small_training_set(), single_filter_options());
  EXPECT_DOUBLE_EQ(residual.upper()[3],
                   single_filter_options().sigma_max * single_filter_options().error_scale);
}

// A toy problem with a known optimum: every gene at 0.3 and every slot active.
class ToyProblem final : public GenomeProblem {
 public:
  ToyProblem() : lower_(20, 0.0), upper_(20, 1.0) {}
  [[nodiscard]] int max_rules() const override { return 4; }
  [[nodiscard]] const std::vector<double>& lower() const override { return lower_; }
  [[nodiscard]] const std::vector<double>& upper() const override { return upper_; }
  [[nodiscard]] Evaluation evaluate(const Genome& genome) const override {
    double distance = 0.0;
    for (double g : genome.genes) distance += (g - 0.3) * (g - 0.3);
    Evaluation e;
    e.rules = genome.rule_count();
    e.error = distance;
    e.fitness = 1.0 / (1.0 + distance) + 0.1 * e.rules;
    return e;
  }

 private:
  std::vector<double> lower_, upper_;
};

TEST(GeneticAlgorithm, SelectionPressureFindsTheKnownOptimum) {
  const ToyProblem problem;
  GaOptions options;
  options.population = 80;
  options.generations = 150;
  options.mutation_rate = 0.05;
  options.mutation_scale = 0.05;
  const GeneticAlgorithm algorithm(problem, options, 5);
  Population population = algorithm.initialize();
  const double initial_best = population.evaluations[population.best_index()].fitness;
  for (int g = 0; g < options.generations; ++g) {
    const double before = population.evaluations[population.best_index()].fitness;
    algorithm.evolve(population);
    ASSERT_GE(population.evaluations[population.best_index()].fitness, before);  // elitism
  }
  const Evaluation& best = population.evaluations[population.best_index()];
  EXPECT_GT(best.fitness, initial_best);
  EXPECT_EQ(best.rules, 4);
  EXPECT_LT(best.error, 0.01);  // every gene within ~0.02 of 0.3
}

std::vector<Genome> evolve_with_threads(int threads) {
  omp_set_num_threads(threads);
  const FuzzyTableProblem problem(small_training_set(), single_filter_options());
  GaOptions options;
  options.population = 40;
  const GeneticAlgorithm algorithm(problem, options, 99);
  Population population = algorithm.initialize();
  for (int g = 0; g < 4; ++g) algorithm.evolve(population);
  return population.genomes;
}

TEST(GeneticAlgorithm, ResultIsIdenticalForAnyThreadCount) {
  const auto one = evolve_with_threads(1);
  const auto two = evolve_with_threads(2);
  const auto four = evolve_with_threads(4);
  ASSERT_EQ(one.size(), two.size());
  for (std::size_t i = 0; i < one.size(); ++i) {
    EXPECT_EQ(one[i].genes, two[i].genes) << i;
    EXPECT_EQ(one[i].active, two[i].active) << i;
    EXPECT_EQ(one[i].genes, four[i].genes) << i;
  }
  omp_set_num_threads(omp_get_num_procs());
}

TEST(Memetic, NeverReturnsAWorseGenome) {
  const FuzzyTableProblem problem(small_training_set(), single_filter_options());
  GaOptions options;
  options.population = 4;
  const GeneticAlgorithm algorithm(problem, options, 1);
  datasets::Rng rng(4);
  const Genome genome = algorithm.random_genome(rng);
  MemeticOptions memetic;
  memetic.max_evaluations = 60;
  const MemeticResult result = polish(problem, genome, memetic);
  EXPECT_GE(result.after.fitness, result.before.fitness);
  EXPECT_GT(result.evaluations, 0);
  EXPECT_EQ(result.genome.active, genome.active);  // the rule set is fixed
}

// A quick config; `ga_extra` goes into [ga], `tail` after every table.
GaTrainingConfig small_config(const std::string& ga_extra = "", const std::string& tail = "") {
  const testing::TempDir dir;
  const std::string text = testing::regime_line(testing::write_ga_regime(dir)) +
                           "seed = 7\n[training]\nlevels = [0.001, 0.05]\n"
                           "[ga]\npopulation = 16\ngenerations = 6\n" +
                           ga_extra + "[memetic]\nmax_evaluations = 20\n" + tail;
  testing::write_text(dir / "small.toml", text);
  return load_ga_config(dir / "small.toml");
}

TEST(GaTrainer, ResumeAfterAStopGivesTheUninterruptedModel) {
  const testing::TempDir dir;
  const GaTrainingConfig config = small_config();
  const GaTrainingResult full = train_ga(config, {dir / "full.h5", false});
  ASSERT_TRUE(full.gate_passed);

  int checkpoints = 0;
  GaObserver stop_early;
  stop_early.should_stop = [&] { return ++checkpoints == 10; };  // mid second level
  const GaTrainingResult stopped = train_ga(config, {dir / "resumed.h5", false}, stop_early);
  EXPECT_TRUE(stopped.stopped);
  EXPECT_FALSE(std::filesystem::exists(dir / "resumed.h5"));
  EXPECT_TRUE(std::filesystem::exists(checkpoint_path(dir / "resumed.h5")));
  int resumed_at = -1;
  GaObserver watch;
  watch.on_resume = [&](std::size_t level, int generation) {
    resumed_at = static_cast<int>(level) * 100 + generation;
  };
  const GaTrainingResult resumed = train_ga(config, {dir / "resumed.h5", true}, watch);
  EXPECT_EQ(resumed_at, 100 + 2);  // level 1, generation 2 (7 checkpoints in level 0)
  ASSERT_TRUE(resumed.gate_passed);
  EXPECT_FALSE(std::filesystem::exists(checkpoint_path(dir / "resumed.h5")));

  const auto a = io::read_ga_fuzzy_imm(dir / "full.h5");
  const auto b = io::read_ga_fuzzy_imm(dir / "resumed.h5");
  ASSERT_EQ(a.levels.size(), b.levels.size());
  for (std::size_t i = 0; i < a.levels.size(); ++i) {
    EXPECT_EQ(io::rules_matrix(a.levels[i].table), io::rules_matrix(b.levels[i].table));
  }
}

// A finished run leaves no checkpoint behind, whether or not its gate passed.
TEST(GaTrainer, FailedGateLeavesNeitherModelNorCheckpoint) {
  const testing::TempDir dir;
  const GaTrainingConfig config = small_config("", "[gate]\nmax_validation_error = 1e-9\n");
  const GaTrainingResult result = train_ga(config, {dir / "m.h5", false});
  EXPECT_FALSE(result.gate_passed);
  EXPECT_FALSE(std::filesystem::exists(dir / "m.h5"));
  EXPECT_FALSE(std::filesystem::exists(checkpoint_path(dir / "m.h5")));
}

TEST(GaTrainer, CheckpointOfAnotherSeedIsRefused) {
  const testing::TempDir dir;
  GaTrainingConfig config = small_config();
  GaObserver stop;
  stop.should_stop = [] { return true; };
  (void)train_ga(config, {dir / "m.h5", false}, stop);
  config.seed = 8;
  EXPECT_THROW((void)train_ga(config, {dir / "m.h5", true}), io::FileError);
}

std::string config_error_key(const std::string& ga_extra, const std::string& tail = "") {
  try {
    (void)small_config(ga_extra, tail);
  } catch (const support::ConfigError& error) {
    return error.key();
  }
  return "";
}

TEST(GaConfig, InvalidValuesAreNamed) {
  EXPECT_EQ(config_error_key("lambda = 1.5\n"), "ga.lambda");
  EXPECT_EQ(config_error_key("", "[fuzzy]\nsigma_range = [-1.0, 2.0]\n"), "fuzzy.sigma_range");
  EXPECT_EQ(config_error_key("crossover = 0.9\n"), "ga.crossover");  // unknown key (in [ga])
  EXPECT_EQ(config_error_key("mutation_rate = \"high\"\n"), "ga.mutation_rate");
  EXPECT_EQ(config_error_key("", "[fuzzy]\nantecedents = \"innovation\"\n"), "fuzzy.antecedents");
  const testing::TempDir dir;
  testing::write_text(dir / "p.toml", testing::regime_line(testing::write_ga_regime(dir)) +
                                          "[ga]\npopulation = 1\n");
  try {
    (void)load_ga_config(dir / "p.toml");
    FAIL();
  } catch (const support::ConfigError& error) {
    EXPECT_EQ(error.key(), "ga.population");
    EXPECT_EQ(error.file(), (dir / "p.toml").string());
  }
}

// Finite but absurd values that used to abort a training run deep inside a parallel region
// (the consequent variances or the residual ranges overflow) are refused at load, naming the key.
TEST(GaConfig, AbsurdFiniteValuesAreRefusedAtLoad) {
  EXPECT_EQ(config_error_key("", "[fuzzy]\nconsequent_range = [0.5, 1e308]\n"),
            "fuzzy.consequent_range");
  // T and σ are the regime's now: its loader refuses them by their own keys.
  const testing::TempDir dir;
  for (const auto& [from, to, key] :
       {std::tuple<std::string, std::string, std::string>{
            "sample_period = 1.0", "sample_period = 1e-320", "sample_period"},
        {"sigma = [0.5, 0.5]", "sigma = [1e308, 1e308]", "sensor.sigma"}}) {
    try {
      (void)datasets::load_regime(
          testing::write_preset_variant(dir, "ga_imm_training", {{from, to}}));
      ADD_FAILURE() << key;
    } catch (const support::ConfigError& error) {
      EXPECT_EQ(error.key(), key);
    }
  }
  EXPECT_EQ(config_error_key("", "[fuzzy]\nsigma_range = [0.05, 1e308]\n"), "fuzzy.sigma_range");
}

TEST(ShippedConfig, IsTheSeedsTable1) {
  const GaTrainingConfig config = load_ga_config("configs/ga_fuzzy_imm.toml");
  EXPECT_EQ(config.ga.population, 500);
  EXPECT_EQ(config.ga.generations, 100);
  EXPECT_EQ(config.fuzzy.max_rules, 50);
  EXPECT_DOUBLE_EQ(config.ga.crossover_rate, 0.9);
  EXPECT_DOUBLE_EQ(config.ga.mutation_rate, 0.01);
  EXPECT_DOUBLE_EQ(config.fuzzy.lambda, 0.95);
  EXPECT_EQ(config.fuzzy.antecedents, FuzzyAntecedents::kResidual);  // the seed's literal form
  ASSERT_EQ(config.levels.size(), 3u);  // "auto": the seed's levels from the training regime
  EXPECT_NEAR(config.levels[0], 0.001, 1e-12);
  EXPECT_NEAR(config.levels[1], 0.01, 1e-12);
  EXPECT_NEAR(config.levels[2], 0.1, 1e-12);
}

// The regime preset: tuned levels resolved by the trainer, λ that lets a rule pay.
TEST(ShippedConfig, TunedPresetStartsFromTheTunedImm) {
  const GaTrainingConfig config = load_ga_config("configs/ga_fuzzy_imm_tuned.toml");
  EXPECT_TRUE(config.tuned_levels);
  EXPECT_TRUE(config.levels.empty());
  EXPECT_EQ(config.level_count, 3);
  EXPECT_TRUE(config.refine_levels);
  EXPECT_EQ(config.fuzzy.fitness, FitnessKind::kImm);
  EXPECT_DOUBLE_EQ(config.fuzzy.lambda, 0.999);
  EXPECT_EQ(config.fuzzy.antecedents, FuzzyAntecedents::kNormalizedInnovation);
  EXPECT_EQ(config.fuzzy.error, ErrorKind::kZeta);  // the figure it is judged by
  EXPECT_EQ(config.fuzzy.max_rules, 3);
  EXPECT_LE(config.fuzzy.consequent_low, 1.0);
  EXPECT_GE(config.fuzzy.consequent_high, 1.0);
}

TEST(ImportRules, ReadsThePublishedTables) {
  AxisImmSettings seed;  // seed 000's, for which the tables were learned
  seed.sample_period = 1.0;
  const auto spec = read_rules_csv("configs/reference/ga_fuzzy_imm_paper_rules.csv", seed, "km");
  ASSERT_EQ(spec.levels.size(), 3u);
  EXPECT_EQ(spec.levels[0].table.size(), 9u);  // Table 2.1
  EXPECT_EQ(spec.levels[1].table.size(), 8u);  // Table 2.2
  EXPECT_EQ(spec.levels[2].table.size(), 8u);  // Table 2.3
  EXPECT_DOUBLE_EQ(spec.levels[0].table.rules()[0].w, 0.215e-5);
  EXPECT_DOUBLE_EQ(spec.levels[2].table.rules()[1].sigma2, 0.039);
  EXPECT_EQ(spec.levels[1].name, "u0.01");
  const testing::TempDir dir;
  testing::write_text(dir / "bad.csv",
                      "level,c1,sigma1,c2,sigma2,w\n0.01,0,1,0,1,1e-4\n0.01,0,-1,0,1,1e-4\n");
  EXPECT_THROW((void)read_rules_csv(dir / "bad.csv", seed, "km"), std::runtime_error);
  testing::write_text(dir / "nan.csv", "level,c1,sigma1,c2,sigma2,w\n0.01,0,1,nan,1,1e-4\n");
  try {
    (void)read_rules_csv(dir / "nan.csv", seed, "km");
    FAIL();
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("nan.csv:2"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace imm::trainer::ga
