// SPDX-License-Identifier: Apache-2.0
// The lane-batched GA-fuzzy IMM against the runtime's ImmEstimator one trajectory at a time
// (evaluate_imm with batched = false is that path), and the GA it drives against the GA the
// runtime path drives.
#include "imm/trainer/ga/imm_fitness_batch.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "imm/datasets/random.hpp"
#include "imm/math/lane_isa.hpp"
#include "imm/trainer/baseline_tuning.hpp"
#include "imm/trainer/ga/fuzzy_table_problem.hpp"
#include "imm/trainer/ga/genetic_algorithm.hpp"
#include "testing/ga_fuzzy_specs.hpp"
#include "testing/ga_training_sets.hpp"

namespace imm::trainer::ga {
namespace {

// 3 tracks of 80 scans: 6 one-axis trajectories, so the block of eight has two empty lanes.
TrainingSet training_set() { return testing::ga_training_set(80, 3, 1); }

using testing::random_ga_fuzzy_spec;

void expect_same_figures(const Evaluation& batch, const Evaluation& runtime, double tolerance) {
  EXPECT_NEAR(batch.position_error, runtime.position_error,
              tolerance * std::abs(runtime.position_error));
  EXPECT_NEAR(batch.velocity_error, runtime.velocity_error,
              tolerance * std::abs(runtime.velocity_error));
  EXPECT_NEAR(batch.fitness, runtime.fitness, tolerance);
  EXPECT_EQ(batch.rules, runtime.rules);
}

Evaluation batched(const ImmFitnessBatch& batch, const GaFuzzyImmSpec& spec,
                   const ProblemOptions& options, int rules) {
  const ImmRunErrors run = batch.run(spec);
  Evaluation e;
  e.rules = rules;
  if (options.error == ErrorKind::kZeta) {
    e.position_error = run.failed ? std::numeric_limits<double>::infinity() : run.zeta_p;
    e.velocity_error = run.failed ? std::numeric_limits<double>::infinity() : run.zeta_v;
  } else {
    e.position_error = run.position_abs_sum / static_cast<double>(run.count);
    e.velocity_error = run.velocity_abs_sum / static_cast<double>(run.count);
  }
  e.fitness = run.failed ? 0.0 : 1.0;
  return e;
}

// Random specs (1 to 5 levels, 1 to 6 rules each, both antecedent kinds, random switching) on
// trajectories of unequal lengths: ζ and eq. (17)'s mean errors agree with the runtime filter's
// to 1e-12 relative (the exp and log differ from libm's by at most 2 ulp).
TEST(ImmFitnessBatch, EqualsTheRuntimeImmOnEveryTrajectoryToRounding) {
  TrainingSet set = training_set();
  ASSERT_EQ(set.trajectories.size(), 6u);
  for (const int cut : {1, 4}) {  // two trajectories end early: masked scans
    auto& t = set.trajectories[static_cast<std::size_t>(cut)];
    const Eigen::Index length = 50 + 7 * cut;
    t.position.conservativeResize(length);
    t.velocity.conservativeResize(length);
    t.measurement.conservativeResize(length);
    t.acceleration_input.conservativeResize(length);
  }
  const ImmFitnessBatch batch(set);
  datasets::Rng rng(5);
  int compared = 0;
  for (int trial = 0; trial < 24; ++trial) {
    const auto antecedents =
        trial % 2 == 0 ? FuzzyAntecedents::kResidual : FuzzyAntecedents::kNormalizedInnovation;
    const GaFuzzyImmSpec spec = random_ga_fuzzy_spec(rng, 1 + trial % 5, antecedents);
    ASSERT_TRUE(ImmFitnessBatch::supports(spec));
    for (const ErrorKind kind : {ErrorKind::kEquation17, ErrorKind::kZeta}) {
      ProblemOptions options;
      options.error = kind;
      const Evaluation runtime = evaluate_imm(spec, set, options, 3);
      ASSERT_TRUE(std::isfinite(runtime.error)) << trial;
      Evaluation fast = batched(batch, spec, options, 3);
      fast.fitness = runtime.fitness;  // compared through the figures
      expect_same_figures(fast, runtime, 1e-12);
      ++compared;
    }
  }
  EXPECT_EQ(compared, 48);
}

// Without truth the batch's predictive NLL per plot is the runtime filter's
// (ImmEstimator::log_predictive_likelihood through axis_zetas), to lane_log's rounding; the
// truth is never read (NaN here).
TEST(ImmFitnessBatch, ItsPredictiveNllIsTheRuntimeFiltersWithoutTruth) {
  TrainingSet set = training_set();
  set.trajectories[2].measurement.conservativeResize(61);  // masked scans
  set.trajectories[2].position.conservativeResize(61);
  set.trajectories[2].velocity.conservativeResize(61);
  set.trajectories[2].acceleration_input.conservativeResize(61);
  set.plots_only = true;
  for (auto& t : set.trajectories) {
    t.position.setConstant(std::nan(""));
    t.velocity.setConstant(std::nan(""));
  }
  const ImmFitnessBatch batch(set);
  datasets::Rng rng(8);
  for (int trial = 0; trial < 12; ++trial) {
    const GaFuzzyImmSpec spec = random_ga_fuzzy_spec(
        rng, 1 + trial % 4,
        trial % 2 == 0 ? FuzzyAntecedents::kResidual : FuzzyAntecedents::kNormalizedInnovation);
    const double runtime =
        axis_zetas([&] { return std::make_unique<ImmAxisFilter>(build_ga_fuzzy_axis_imm(spec)); },
                   {set})
            .position;
    ASSERT_TRUE(std::isfinite(runtime)) << trial;
    const double fast = batch.run(spec).predictive_nll - set.nll_floor();
    EXPECT_NEAR(fast, runtime, 1e-12 * std::abs(set.nll_floor())) << trial;
  }
}

// The layouts of both instruction sets (blocks of 24 and 16 where the AVX-512 clones run, of 8
// elsewhere) give the same bits, with and without truth: 26 trajectories are 24 + 4 (two empty
// lanes) in one and 8 + 8 + 8 + 4 in the other, two of them shorter (masked scans). The sums run in
// trajectory order in both. Both layouts run here whatever the CPU (the clone does not).
// The step's packs of 8 (AVX-512), 4 (AVX2) and 2 (lane_isa.hpp) give the same bits, both layouts,
// with and without truth: each instruction set this CPU runs, side by side.
TEST(ImmFitnessBatch, EveryInstructionSetGivesTheSameBits) {
  struct Uncap {
    ~Uncap() { cap_lane_isa(LaneIsa::kAvx512); }
  } uncap;
  TrainingSet set = testing::ga_training_set(40, 13, 2);
  TrainingSet plots = set;
  plots.plots_only = true;
  datasets::Rng rng(12);
  for (const TrainingSet* data : {&set, &plots}) {
    for (const bool wide : {true, false}) {
      const ImmFitnessBatch batch(*data, wide);
      for (int trial = 0; trial < 4; ++trial) {
        const GaFuzzyImmSpec spec = random_ga_fuzzy_spec(
            rng, 1 + trial % 4,
            trial % 2 == 0 ? FuzzyAntecedents::kResidual : FuzzyAntecedents::kNormalizedInnovation);
        cap_lane_isa(LaneIsa::kAvx512);
        const ImmRunErrors a = batch.run(spec);
        for (const LaneIsa isa : {LaneIsa::kAvx2, LaneIsa::kBaseline}) {
          cap_lane_isa(isa);
          const ImmRunErrors b = batch.run(spec);
          EXPECT_EQ(a.failed, b.failed);
          EXPECT_EQ(a.count, b.count);
          EXPECT_EQ(a.position_abs_sum, b.position_abs_sum) << trial;
          EXPECT_EQ(a.velocity_abs_sum, b.velocity_abs_sum) << trial;
          EXPECT_EQ(a.predictive_nll, b.predictive_nll) << trial;
        }
      }
    }
  }
}

TEST(ImmFitnessBatch, TheWideAndNarrowLayoutsGiveTheSameBits) {
  TrainingSet set = testing::ga_training_set(60, 13, 2);
  ASSERT_EQ(set.trajectories.size(), 26u);
  for (const int cut : {5, 23}) {
    auto& t = set.trajectories[static_cast<std::size_t>(cut)];
    t.position.conservativeResize(41);
    t.velocity.conservativeResize(41);
    t.measurement.conservativeResize(41);
    t.acceleration_input.conservativeResize(41);
  }
  TrainingSet plots = set;
  plots.plots_only = true;
  datasets::Rng rng(11);
  for (const TrainingSet* data : {&set, &plots}) {
    const ImmFitnessBatch wide(*data, true);
    const ImmFitnessBatch narrow(*data, false);
    for (int trial = 0; trial < 6; ++trial) {
      const GaFuzzyImmSpec spec = random_ga_fuzzy_spec(
          rng, 1 + trial % 4,
          trial % 2 == 0 ? FuzzyAntecedents::kResidual : FuzzyAntecedents::kNormalizedInnovation);
      const ImmRunErrors a = wide.run(spec);
      const ImmRunErrors b = narrow.run(spec);
      ASSERT_FALSE(a.failed) << trial;
      EXPECT_EQ(a.failed, b.failed);
      EXPECT_EQ(a.count, b.count);
      EXPECT_EQ(a.position_abs_sum, b.position_abs_sum) << trial;
      EXPECT_EQ(a.velocity_abs_sum, b.velocity_abs_sum) << trial;
      EXPECT_EQ(a.zeta_p, b.zeta_p) << trial;
      EXPECT_EQ(a.zeta_v, b.zeta_v) << trial;
      EXPECT_EQ(a.predictive_nll, b.predictive_nll) << trial;
    }
  }
}

// A plot the filter cannot take fails the run on both paths; in a masked lane it is never read.
TEST(ImmFitnessBatch, AFailedStepFailsTheRunLikeTheRuntimeFilter) {
  TrainingSet set = training_set();
  set.trajectories[2].measurement(30) = std::numeric_limits<double>::quiet_NaN();
  datasets::Rng rng(9);
  const GaFuzzyImmSpec spec = random_ga_fuzzy_spec(rng, 3, FuzzyAntecedents::kResidual);
  ProblemOptions options;
  EXPECT_FALSE(std::isfinite(evaluate_imm(spec, set, options, 1).error));
  EXPECT_TRUE(ImmFitnessBatch(set).run(spec).failed);
  // A finite plot beyond the physical limits: the runtime refuses it, and so does the batch.
  TrainingSet far = training_set();
  far.trajectories[4].measurement(40) = 1e30;
  EXPECT_FALSE(std::isfinite(evaluate_imm(spec, far, options, 1).error));
  EXPECT_TRUE(ImmFitnessBatch(far).run(spec).failed);
  EXPECT_FALSE(ImmFitnessBatch(training_set()).run(spec).failed);

  // Without switching (stay 1) the mode prediction may be zero: the batch declines the spec.
  GaFuzzyImmSpec sticky = spec;
  sticky.settings.transition_stay = 1.0;
  EXPECT_FALSE(ImmFitnessBatch::supports(sticky));
  EXPECT_THROW((void)ImmFitnessBatch(training_set()).run(sticky), std::invalid_argument);
}

// The GA scored by the batch keeps the genomes the GA scored by the runtime filter keeps, genome
// for genome, on a short run of the IMM fitness; the fitness values agree to rounding.
TEST(ImmFitnessBatch, TheGaItDrivesKeepsTheRuntimePathsGenomes) {
  const TrainingSet set = training_set();
  datasets::Rng rng(3);
  ImmContext context;
  const GaFuzzyImmSpec spec = random_ga_fuzzy_spec(rng, 3, FuzzyAntecedents::kNormalizedInnovation);
  context.settings = spec.settings;
  context.levels = spec.levels;
  context.slot = 1;
  ProblemOptions options;
  options.antecedents = FuzzyAntecedents::kNormalizedInnovation;
  options.error = ErrorKind::kZeta;
  options.max_rules = 6;
  options.error_scale = 0.5;
  options.batched = true;
  const FuzzyTableProblem fast(set, options, context);
  options.batched = false;
  const FuzzyTableProblem runtime(set, options, context);
  GaOptions ga;
  ga.population = 24;
  const GeneticAlgorithm fast_ga(fast, ga, 17), runtime_ga(runtime, ga, 17);
  Population a = fast_ga.initialize(), b = runtime_ga.initialize();
  for (int generation = 0; generation <= 4; ++generation) {
    if (generation > 0) {
      fast_ga.evolve(a);
      runtime_ga.evolve(b);
    }
    for (std::size_t i = 0; i < a.genomes.size(); ++i) {
      ASSERT_EQ(a.genomes[i].genes, b.genomes[i].genes) << "generation " << generation;
      ASSERT_EQ(a.genomes[i].active, b.genomes[i].active) << "generation " << generation;
      EXPECT_NEAR(a.evaluations[i].fitness, b.evaluations[i].fitness, 1e-13);
    }
  }
}

}  // namespace
}  // namespace imm::trainer::ga
