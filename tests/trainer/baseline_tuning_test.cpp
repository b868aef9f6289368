// SPDX-License-Identifier: Apache-2.0
// The GA-fuzzy IMM contains its tuned baseline: one constant rule per level is the constant-q IMM,
// a tuned-levels run starts from that IMM and never ends below it, and the joint tuning of the
// stay probability never scores worse than the levels alone.
#include "imm/trainer/baseline_tuning.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "imm/datasets/random.hpp"
#include "imm/datasets/regime_file.hpp"
#include "imm/datasets/sensor_estimate.hpp"
#include "imm/filters/axis_cv_imm.hpp"
#include "imm/filters/ga_fuzzy_imm.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/io/model_file.hpp"
#include "imm/trainer/ga/ga_config.hpp"
#include "imm/trainer/ga/ga_trainer.hpp"
#include "imm/trainer/ga/genetic_algorithm.hpp"
#include "imm/trainer/ga/tuned_levels.hpp"
#include "imm/trainer/regime_checks.hpp"
#include "testing/ga_training_sets.hpp"
#include "testing/regime_files.hpp"
#include "testing/temp_dir.hpp"

namespace imm::trainer::ga {
namespace {

// A planted regime: constant-velocity targets with white acceleration of σ_w = 2 m/s² (q = 4),
// plots of σ = 20 m every second. From the plots alone (the truth set to NaN, so nothing can read
// it), the constant-q IMM tuned by its predictive likelihood and the plot σ fit recover q and σ
// within their sampling error (over 8 seeds of 20 tracks: q 3.98 ± 0.22, σ 19.98 ± 0.11).
TEST(TrainingWithoutTruth, RecoversThePlantedProcessNoiseAndPlotSigma) {
  const datasets::Regime regime =
      datasets::parse_regime(
          "name = \"planted\"\nunits = \"m\"\nsample_period = 1.0\nscans = 200\n"
          "process_noise_sigma = 2.0\n[sensor]\nkind = \"cartesian\"\nsigma = [20.0, 20.0]\n"
          "[start]\nrange = [1000.0, 2000.0]\nspeed = [50.0, 100.0]\n[[maneuvers]]\nkind = \"cv\"\n"
          "probability = 1.0\nduration = [10.0, 20.0]\n[splits]\ntraining = 20\nvalidation = 5\n"
          "test = 5\nseed = 3\n",
          "planted.toml")
          .regime;
  TrainingSet set = make_training_set(regime, datasets::Split::kTraining);
  set.plots_only = true;
  for (auto& t : set.trajectories) {
    t.position.setConstant(std::nan(""));
    t.velocity.setConstant(std::nan(""));
  }
  AxisCvImmSpec base;
  base.settings.sample_period = 1.0;
  base.settings.sample_period = 1.0;
  base.settings.measurement_sigma = 20.0;
  const Tuned<AxisCvImmSpec> tuned =
      tune_axis_cv_imm(base, {set}, 10.0, 1, TransitionTuning::kFixed);
  EXPECT_NEAR(tuned.spec.process_noise[0], 4.0, 0.6);  // ~3 sampling σ
  EXPECT_TRUE(std::isfinite(tuned.score));
  const datasets::PlotSigmaFit fit =
      datasets::fit_plot_sigma(datasets::draw_split(regime, datasets::Split::kTraining, 1));
  EXPECT_NEAR(fit.model.sigma, 20.0, 0.4);
  // With the truth, ζ is what is tuned, and the criterion says which.
  EXPECT_STREQ(set.criterion(), "excess NLL per plot");
  EXPECT_STREQ(make_training_set(regime, datasets::Split::kTraining).criterion(), "ζ_p + ζ_v");
}

// Plots of a target that flies straight, then accelerates, then flies straight again.
std::vector<double> maneuvering_plots(int scans, double sigma, std::uint64_t seed) {
  datasets::Rng rng(seed);
  std::vector<double> z;
  double p = 0.0, v = 0.2;
  for (int k = 0; k < scans; ++k) {
    const double a = k >= 40 && k < 60 ? 0.03 : 0.0;
    p += v + 0.5 * a;
    v += a;
    z.push_back(p + rng.normal(0.0, sigma));
  }
  return z;
}

// With either antecedents (a table of one rule answers its consequent whatever it reads).
class OneConstantRulePerLevel : public ::testing::TestWithParam<FuzzyAntecedents> {};

TEST_P(OneConstantRulePerLevel, IsTheConstantNoiseImm) {
  AxisCvImmSpec imm;
  imm.settings.sample_period = 1.0;
  imm.settings.sample_period = 1.0;
  imm.settings.measurement_sigma = 0.5;
  imm.settings.transition_stay = 0.931;
  imm.process_noise = {1e-7, 3e-5, 2e-3};
  GaFuzzyImmSpec fuzzy;
  fuzzy.settings.sample_period = 1.0;
  fuzzy.settings = imm.settings;
  fuzzy.antecedents = GetParam();
  for (double q : imm.process_noise) {
    // Any premise: one rule's inference is its consequent wherever it fires.
    fuzzy.levels.push_back({"level", std::sqrt(q), FuzzyRuleTable({{0.3, 0.2, -0.1, 0.05, q}})});
  }
  ImmEstimator<2, 1> a = build_axis_cv_imm(imm);
  ImmEstimator<2, 1> b = build_ga_fuzzy_axis_imm(fuzzy);
  GaussianState<2> start;
  start.mean << 0.0, 0.2;
  start.covariance << 0.25, 0.25, 0.25, 0.5;
  a.initialize(start);
  b.initialize(start);
  for (double z : maneuvering_plots(120, 0.5, 5)) {
    ASSERT_EQ(a.step(Vector<1>(z)), StepStatus::kOk);
    ASSERT_EQ(b.step(Vector<1>(z)), StepStatus::kOk);
    for (int i = 0; i < 2; ++i) {
      EXPECT_NEAR(b.estimate().mean(i), a.estimate().mean(i),
                  1e-12 * (1.0 + std::abs(a.estimate().mean(i))));
      for (int j = 0; j < 2; ++j) {
        EXPECT_NEAR(b.estimate().covariance(i, j), a.estimate().covariance(i, j),
                    1e-12 * (1.0 + std::abs(a.estimate().covariance(i, j))));
      }
    }
    for (int j = 0; j < 3; ++j) {
      EXPECT_NEAR(b.mode_probabilities()(j), a.mode_probabilities()(j), 1e-12);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(TunedBaseline, OneConstantRulePerLevel,
                         ::testing::Values(FuzzyAntecedents::kResidual,
                                           FuzzyAntecedents::kNormalizedInnovation));

TEST(TunedBaseline, JointStayTuningIsNeverWorseThanTheLevelsAlone) {
  const testing::TempDir dir;
  const TrainingSet training = testing::training_split(testing::write_ga_regime(dir, 60, 2, 1));
  AxisCvImmSpec base;
  base.settings.sample_period = 1.0;
  base.settings.measurement_sigma = 0.5;
  base.settings.transition_stay = 0.97;
  const Tuned<AxisCvImmSpec> fixed =
      tune_axis_cv_imm(base, {training}, 0.05, 2, TransitionTuning::kFixed);
  const Tuned<AxisCvImmSpec> joint =
      tune_axis_cv_imm(base, {training}, 0.05, 2, TransitionTuning::kJointly);
  EXPECT_EQ(fixed.spec.settings.transition_stay, 0.97);
  EXPECT_LE(joint.score, fixed.score);
  EXPECT_GT(joint.evaluations, fixed.evaluations);
  // The reported score is the score of the reported spec.
  EXPECT_DOUBLE_EQ(
      joint.score,
      axis_score([&] { return std::make_unique<ImmAxisFilter>(build_axis_cv_imm(joint.spec)); },
                 {training}));
}

TEST(GeneticAlgorithm, SeedGenomesOpenThePopulationAndTheRestIsUnchanged) {
  const testing::TempDir dir;
  ProblemOptions options;
  options.maneuver_level = 0.01;
  options.fitness = FitnessKind::kSingleFilter;
  const FuzzyTableProblem problem(testing::training_split(testing::write_ga_regime(dir)), options);
  GaOptions ga;
  ga.population = 8;
  const GeneticAlgorithm algorithm(problem, ga, 4);
  const Genome seed = problem.constant_genome(0.008);
  const std::vector<Genome> seeds{seed};
  const Population plain = algorithm.initialize();
  const Population seeded = algorithm.initialize(seeds);
  EXPECT_EQ(seeded.genomes[0].genes, seed.genes);
  EXPECT_EQ(seeded.genomes[0].rule_count(), 1);
  for (std::size_t i = 1; i < plain.genomes.size(); ++i) {
    EXPECT_EQ(seeded.genomes[i].genes, plain.genomes[i].genes);
  }
  // Its table is the constant q = 0.008².
  const FuzzyRuleTable table = problem.decode(seed);
  ASSERT_EQ(table.size(), 1u);
  EXPECT_NEAR(table.rules()[0].w, 0.008 * 0.008, 1e-18);
  Genome outside = seed;
  outside.genes[4] = problem.upper()[4] * 2.0;
  const std::vector<Genome> bad{outside};
  EXPECT_THROW((void)algorithm.initialize(bad), std::invalid_argument);
}

GaTrainingConfig tuned_config(const testing::TempDir& dir, const std::string& training_extra) {
  const std::string text = testing::regime_line(testing::write_ga_regime(dir, 60, 2, 1)) +
                           "seed = 3\n[training]\nlevels = \"tuned\"\nlevel_count = 2\n" +
                           training_extra +
                           "[fuzzy]\nconsequent_range = [0.25, 4.0]\n"
                           "[ga]\npopulation = 12\ngenerations = 4\n"
                           "[memetic]\nenabled = false\nmax_evaluations = 60\n";
  testing::write_text(dir / "tuned.toml", text);
  return load_ga_config(dir / "tuned.toml");
}

// Levels the config chose itself are checked against the quietest behaviour of the regime: a
// quietest level whose consequent floor lies far above the tuned IMM's lowest q is warned about
// (with both numbers); levels at the tuned IMM's own q are not; tuned levels are never.
TEST(GaTrainer, WarnsWhenTheQuietestLevelCannotReachTheTunedImmsQuietestQ) {
  const testing::TempDir dir;
  const GaTrainingConfig tuned = tuned_config(dir, "");
  const TrainingSet training = make_training_set(tuned.regime, datasets::Split::kTraining);
  EXPECT_FALSE(unreachable_quiet_level(tuned, training));
  const GaTrainingConfig resolved = resolve_levels(tuned, training);

  GaTrainingConfig chosen = tuned;
  chosen.tuned_levels = false;
  chosen.fuzzy.consequent_low = 0.5;
  chosen.regime.process_noise_sigma = 0.0;  // the floor is then 0.5 · a_M alone
  // 100 times the tuned IMM's √q at the quietest level: the floor (0.5 · a_M)² is 2500 times q.
  const double quiet_q = *std::min_element(resolved.baseline->process_noise.begin(),
                                           resolved.baseline->process_noise.end());
  chosen.levels = {100.0 * std::sqrt(quiet_q), 1000.0 * std::sqrt(quiet_q)};
  chosen.validate();
  const auto warning = unreachable_quiet_level(chosen, training);
  ASSERT_TRUE(warning);
  EXPECT_NE(warning->find("cannot go below"), std::string::npos) << *warning;
  EXPECT_NE(warning->find("levels = \"tuned\""), std::string::npos) << *warning;

  // Levels that reach the tuned q (floor 0.5² · 4 q = q) draw no warning.
  chosen.levels = {2.0 * std::sqrt(quiet_q), 1000.0 * std::sqrt(quiet_q)};
  EXPECT_FALSE(unreachable_quiet_level(chosen, training));
}

// Tuned levels: the levels and the stay probability are the tuned IMM's, the GA starts from it
// and (by elitism) never ends below it on the training split; the joint refinement never makes
// the training ζ_p + ζ_v worse; the validation check keeps the tables only when they beat the
// tuned IMM there.
TEST(GaTrainer, TunedLevelsStartFromTheTunedImmAndNeverEndBelowIt) {
  const testing::TempDir dir;
  const GaTrainingConfig config = tuned_config(dir, "refine_levels = true\n");
  EXPECT_TRUE(config.tuned_levels);
  EXPECT_TRUE(config.levels.empty());
  const TrainingSet training = make_training_set(config.regime, datasets::Split::kTraining);
  const GaTrainingConfig resolved = resolve_levels(config, training);
  ASSERT_TRUE(resolved.baseline);
  ASSERT_EQ(resolved.levels.size(), 2u);
  EXPECT_NEAR(resolved.levels[0] * resolved.levels[0], resolved.baseline->process_noise[0], 1e-15);
  EXPECT_EQ(resolved.filter.transition_stay, resolved.baseline->transition_stay);

  AxisCvImmSpec baseline;
  baseline.settings.sample_period = 1.0;
  baseline.settings = resolved.filter;
  baseline.process_noise = resolved.baseline->process_noise;
  const Evaluation baseline_error = [&] {
    GaFuzzyImmSpec spec;
    spec.settings.sample_period = 1.0;
    spec.settings = resolved.filter;
    for (double q : baseline.process_noise) {
      spec.levels.push_back({"q", std::sqrt(q), FuzzyRuleTable({{0.0, 1.0, 0.0, 1.0, q}})});
    }
    return evaluate_imm(spec, training, resolved.problem_options(0), 2);
  }();

  const GaTrainingResult result = train_ga(resolved, {dir / "m.h5", false});
  ASSERT_TRUE(result.gate_passed) << result.gate_message;
  ASSERT_TRUE(result.refinement);
  EXPECT_LE(result.refinement->after.error, result.refinement->before.error);
  const GaFuzzyImmSpec trained = spec_from(result.config, result.levels);
  const Evaluation trained_error = evaluate_imm(trained, training, resolved.problem_options(0), 2);
  // By elitism the GA's tables are never worse than the constant rules in its own error; the
  // refinement then trades in ζ_p + ζ_v.
  if (!result.refinement->accepted) {
    EXPECT_LE(trained_error.error, baseline_error.error * (1.0 + 1e-12));
  }
  EXPECT_DOUBLE_EQ(trained_error.error, result.levels.back().training.error);

  // The validation check: kept tables beat the tuned IMM there; otherwise the model is that IMM.
  ASSERT_TRUE(result.baseline_check);
  const io::ModelFileReader reader(dir / "m.h5", io::kGaFuzzyImmKind);
  EXPECT_EQ(reader.provenance().training_metrics.at("learned_part_on"),
            result.baseline_check->learned_part_on ? 1.0 : 0.0);
  const GaFuzzyImmSpec shipped = io::read_ga_fuzzy_imm(dir / "m.h5");
  if (result.baseline_check->learned_part_on) {
    EXPECT_LT(result.baseline_check->learned.error, result.baseline_check->baseline.error);
  } else {
    EXPECT_EQ(shipped.settings.transition_stay, resolved.baseline->transition_stay);
    for (std::size_t j = 0; j < shipped.levels.size(); ++j) {
      ASSERT_EQ(shipped.levels[j].table.size(), 1u);
      EXPECT_EQ(shipped.levels[j].table.rules()[0].w, resolved.baseline->process_noise[j]);
    }
  }

  // The config is refused where tuned levels cannot work.
  EXPECT_THROW((void)tuned_config(dir, "fitness = \"single\"\n"), std::exception);
}

}  // namespace
}  // namespace imm::trainer::ga
