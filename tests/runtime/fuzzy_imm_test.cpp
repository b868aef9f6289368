// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "imm/filters/aimm.hpp"
#include "imm/filters/axis_cv_imm.hpp"
#include "imm/filters/fuzzy_noise_filter.hpp"
#include "imm/filters/ga_fuzzy_imm.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/models/measurement/position_measurement.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "testing/hdf5_edit.hpp"
#include "testing/matrix_checks.hpp"
#include "testing/model_files.hpp"
#include "testing/temp_dir.hpp"

namespace imm {
namespace {

// Two rules, by hand at (r, Δr) = (1, 0):
//   rule 1: c = (0, 0), σ = (1, 1), w = 2: firing = exp(−½(1 + 0)) = e^{−1/2}
//   rule 2: c = (1, 1), σ = (2, 1), w = 8: firing = exp(−½(0 + 1)) = e^{−1/2}
//   q = (2 + 8)/2 = 5. At (0, 0): f₁ = 1, f₂ = exp(−½(¼ + 1)) = e^{−5/8}, q = (2 + 8 e^{−5/8})/(1 +
//   e^{−5/8}).
TEST(FuzzyRuleTable, InferenceMatchesHandComputation) {
  const FuzzyRuleTable table({{0.0, 1.0, 0.0, 1.0, 2.0}, {1.0, 2.0, 1.0, 1.0, 8.0}});
  EXPECT_NEAR(table.process_noise(1.0, 0.0), 5.0, 1e-15);
  const double f2 = std::exp(-5.0 / 8.0);
  EXPECT_NEAR(table.process_noise(0.0, 0.0), (2.0 + 8.0 * f2) / (1.0 + f2), 1e-15);
  EXPECT_DOUBLE_EQ(table.mean_w(), 5.0);
}

TEST(FuzzyRuleTable, AllRulesUnderflowFallsBackToTheMeanW) {
  const FuzzyRuleTable table({{0.0, 0.1, 0.0, 0.1, 1e-6}, {0.5, 0.1, 0.0, 0.1, 3e-6}});
  // 100 σ from every rule: every firing strength is exp(−5000) = 0 in double.
  const double q = table.process_noise(10.0, 10.0);
  EXPECT_TRUE(std::isfinite(q));
  EXPECT_DOUBLE_EQ(q, 2e-6);
}

TEST(FuzzyRuleTable, RejectsInvalidRules) {
  EXPECT_THROW(FuzzyRuleTable(std::vector<FuzzyRule>{}), std::invalid_argument);
  EXPECT_THROW(FuzzyRuleTable({{0.0, 0.0, 0.0, 1.0, 1.0}}), std::invalid_argument);
  EXPECT_THROW(FuzzyRuleTable({{0.0, 1.0, 0.0, 1.0, -1.0}}), std::invalid_argument);
  EXPECT_THROW(FuzzyRuleTable({{std::nan(""), 1.0, 0.0, 1.0, 1.0}}), std::invalid_argument);
  EXPECT_THROW(FuzzyRuleTable(std::vector<FuzzyRule>(51, FuzzyRule{})), std::invalid_argument);
}

// One rule of constant w: q(k) = w whatever the residual, so the fuzzy-noise KF is the ordinary CV
// KF with Q = w G Gᵀ.
TEST(FuzzyNoiseFilter, OneRuleTableIsAnOrdinaryKalmanFilter) {
  const double w = 3e-4, T = 1.0, r = 0.25;
  const FuzzyNoiseFilter fuzzy(FuzzyRuleTable({{0.3, 0.5, -0.2, 0.7, w}}), T, r);
  const auto motion = constant_velocity<1>(T, w);
  const PositionMeasurement<2, 1> measurement({0}, SquareMatrix<1>::Constant(r));
  GaussianState<2> a, b;
  a.mean << 1.0, 0.05;
  a.covariance << 0.3, 0.01, 0.01, 0.02;
  b = a;
  double residual = 0.0;
  for (int k = 1; k <= 50; ++k) {
    const double z = 1.0 + 0.05 * k + 0.3 * std::sin(0.7 * k);
    const auto step = fuzzy.step(a, residual, z);
    ASSERT_TRUE(step.status == StepStatus::kOk);
    EXPECT_DOUBLE_EQ(step.process_noise, w);
    residual = step.residual;
    b = predict(b, motion.transition, motion.process_noise);
    const auto report = update(b, Vector<1>(z), measurement);
    EXPECT_NEAR(step.residual, report.innovation(0), 1e-12);
    EXPECT_NEAR(step.log_likelihood, report.log_likelihood, 1e-12);
    ASSERT_TRUE(testing::matrices_near(a.mean, b.mean, 1e-12));
    ASSERT_TRUE(testing::matrices_near(a.covariance, b.covariance, 1e-12));
  }
}

// The residual change uses the mode's own previous residual; q follows the table.
TEST(FuzzyNoiseFilter, ProcessNoiseFollowsResidualAndItsChange) {
  // q = 1e-6 near (0, 0), 1e-2 near (2, 2).
  const FuzzyRuleTable table({{0.0, 0.5, 0.0, 0.5, 1e-6}, {2.0, 0.5, 2.0, 0.5, 1e-2}});
  const FuzzyNoiseFilter filter(table, 1.0, 0.25);
  GaussianState<2> state;
  state.mean.setZero();
  state.covariance = 0.01 * SquareMatrix<2>::Identity();
  const auto step = filter.step(state, 0.0, 2.0);  // r = 2, Δr = 2
  EXPECT_DOUBLE_EQ(step.residual, 2.0);
  EXPECT_NEAR(step.process_noise, table.process_noise(2.0, 2.0), 1e-18);
  EXPECT_GT(step.process_noise, 0.9e-2);
  GaussianState<2> untouched = state;
  EXPECT_EQ(filter.step(untouched, 0.0, std::nan("")).status, StepStatus::kInvalidMeasurement);
  EXPECT_EQ(untouched.mean, state.mean);
}

// By hand: x̂ = 0, P = 0.01 I, T = 1, R = 0.25: (F P Fᵀ)₀₀ = P₀₀ + 2T P₀₁ + T² P₁₁ = 0.02, so
// S̄ = 0.27; z = 2 gives r = 2 and ñ = 2/√0.27, Δñ = ñ − 0.5 after a previous ñ of 0.5.
TEST(FuzzyNoiseFilter, NormalizedAntecedentsReadTheInnovationOverItsStandardDeviation) {
  const FuzzyRuleTable table({{0.0, 1.0, 0.0, 1.0, 1e-6}, {3.0, 1.0, 3.0, 1.0, 1e-2}});
  const FuzzyNoiseFilter filter(table, 1.0, 0.25, FuzzyAntecedents::kNormalizedInnovation);
  EXPECT_EQ(filter.antecedents(), FuzzyAntecedents::kNormalizedInnovation);
  GaussianState<2> state;
  state.mean.setZero();
  state.covariance = 0.01 * SquareMatrix<2>::Identity();
  const auto step = filter.step(state, 0.5, 2.0);
  const double normalized = 2.0 / std::sqrt(0.27);
  EXPECT_DOUBLE_EQ(step.residual, 2.0);
  EXPECT_NEAR(step.antecedent, normalized, 1e-15);
  EXPECT_NEAR(step.process_noise, table.process_noise(normalized, normalized - 0.5), 1e-18);
  // The seed's form reads r = 2 and Δr = 1.5 with the same table.
  GaussianState<2> raw_state;
  raw_state.mean.setZero();
  raw_state.covariance = 0.01 * SquareMatrix<2>::Identity();
  const auto raw = FuzzyNoiseFilter(table, 1.0, 0.25).step(raw_state, 0.5, 2.0);
  EXPECT_DOUBLE_EQ(raw.antecedent, 2.0);
  EXPECT_NEAR(raw.process_noise, table.process_noise(2.0, 1.5), 1e-18);
}

// A normalized table means the same at any scale: plots, state and R scaled by s, the table's
// consequents (variances) by s², and every estimate scales by s, q by s². The residual table of
// the same rules does not (its centers and spreads are lengths).
TEST(FuzzyNoiseFilter, NormalizedTableMeansTheSameAtAnyScale) {
  const std::vector<FuzzyRule> rules = {{0.0, 1.0, 0.0, 1.5, 4.0}, {2.5, 1.0, 1.0, 2.0, 400.0}};
  // The residual table: the same rules with centers and spreads in metres of a 100 m plot σ.
  auto scaled_rules = [&](double s, FuzzyAntecedents antecedents) {
    std::vector<FuzzyRule> out = rules;
    for (FuzzyRule& rule : out) {
      rule.w *= s * s;
      if (antecedents == FuzzyAntecedents::kResidual) {
        rule.c1 *= 100.0, rule.sigma1 *= 100.0, rule.c2 *= 100.0, rule.sigma2 *= 100.0;
      }
    }
    return FuzzyRuleTable(out);
  };
  auto run = [&](double s, FuzzyAntecedents antecedents, std::vector<double>& noise) {
    const FuzzyNoiseFilter filter(scaled_rules(s, antecedents), 1.0, 100.0 * 100.0 * s * s,
                                  antecedents);
    GaussianState<2> state;
    state.mean << 0.0, 200.0 * s;
    state.covariance << 1e4 * s * s, 1e4 * s * s, 1e4 * s * s, 2e4 * s * s;
    double previous = 0.0;
    for (int k = 1; k <= 60; ++k) {
      // A target that turns at k = 30 (a lateral 40 m/s² from then on), with a fixed noise.
      const double t = k;
      const double truth = 200.0 * t + (k > 30 ? 20.0 * (t - 30.0) * (t - 30.0) : 0.0);
      const auto step = filter.step(state, previous, s * (truth + 80.0 * std::sin(1.7 * k)));
      EXPECT_EQ(step.status, StepStatus::kOk);
      previous = step.antecedent;
      noise.push_back(step.process_noise);
    }
    return state;
  };
  for (const double s : {1e-3, 7.0}) {
    std::vector<double> q1, qs;
    const GaussianState<2> one = run(1.0, FuzzyAntecedents::kNormalizedInnovation, q1);
    const GaussianState<2> scaled = run(s, FuzzyAntecedents::kNormalizedInnovation, qs);
    EXPECT_TRUE(testing::matrices_near(scaled.mean / s, one.mean, 1e-9 * one.mean.norm()));
    for (std::size_t k = 0; k < q1.size(); ++k) EXPECT_NEAR(qs[k] / (s * s), q1[k], 1e-9 * q1[k]);
    std::vector<double> r1, rs;
    (void)run(1.0, FuzzyAntecedents::kResidual, r1);
    (void)run(s, FuzzyAntecedents::kResidual, rs);
    double largest = 0.0;
    for (std::size_t k = 0; k < r1.size(); ++k) {
      largest = std::max(largest, std::abs(rs[k] / (s * s) - r1[k]) / r1[k]);
    }
    EXPECT_GT(largest, 0.1) << "a residual table read at another scale reads other inputs";
  }
}

TEST(AxisImmSettings, TransitionAndInitialProbabilitiesFollowEquations20And21) {
  AxisImmSettings s;
  s.sample_period = 1.0;
  const Eigen::MatrixXd pi = s.transition(3);
  EXPECT_DOUBLE_EQ(pi(0, 0), 0.97);
  EXPECT_NEAR(pi(0, 1), 0.015, 1e-15);
  EXPECT_NEAR(pi(2, 1), 0.015, 1e-15);
  const Eigen::VectorXd mu = s.initial_probabilities(3);
  EXPECT_DOUBLE_EQ(mu(0), 0.6);
  EXPECT_DOUBLE_EQ(mu(1), 0.2);
  EXPECT_DOUBLE_EQ(s.transition(1)(0, 0), 1.0);
}

// Noise-free constant acceleration: the augmented (two-stage) estimator's â converges to it.
TEST(AccelerationEstimator, ConvergesToAConstantAcceleration) {
  AccelerationEstimator estimator(1.0, 0.001, 0.01, 0.25);
  GaussianState<2> start;
  start.mean << 0.0, 0.0;
  start.covariance = SquareMatrix<2>::Identity();
  estimator.initialize(start, 1e-4);
  const double a = 0.03;
  for (int k = 1; k <= 300; ++k) ASSERT_EQ(estimator.step(0.5 * a * k * k), StepStatus::kOk);
  EXPECT_NEAR(estimator.acceleration(), a, 1e-3);
}

TEST(InputKalmanMode, PredictsWithTheInput) {
  InputKalmanMode mode("a", 2.0, 0.0, 1.0);
  mode.set_input(0.5);
  GaussianState<2> mixed;
  mixed.mean << 1.0, 2.0;
  mixed.covariance = 1e-12 * SquareMatrix<2>::Identity();
  ASSERT_EQ(mode.propose_prediction(mixed).status, StepStatus::kOk);
  mode.commit();
  Vector<2> mean;
  SquareMatrix<2> covariance;
  mode.embedded_estimate(mean, covariance);
  // p = 1 + 2·2 + ½·0.5·4 = 6, v = 2 + 0.5·2 = 3
  EXPECT_DOUBLE_EQ(mean(0), 6.0);
  EXPECT_DOUBLE_EQ(mean(1), 3.0);
}

// The AIMM's sub-models are centered on the estimated acceleration: on a long constant
// acceleration the zero-offset mode ends up most probable and the estimate unbiased.
TEST(AimmAxisFilter, TracksAConstantAccelerationWithItsCentralModel) {
  AimmSpec spec;
  spec.settings.sample_period = 1.0;
  spec.intervals = {0.02, 0.04};
  AimmAxisFilter filter(spec);
  GaussianState<2> start;
  start.mean << 0.0, 0.0;
  start.covariance = SquareMatrix<2>::Identity();
  filter.initialize(start);
  const double a = 0.05;
  for (int k = 1; k <= 200; ++k) ASSERT_EQ(filter.step(0.5 * a * k * k), StepStatus::kOk);
  EXPECT_NEAR(filter.acceleration(), a, 1e-3);
  const ModeVector mu = filter.mode_probabilities();
  Eigen::Index best = 0;
  mu.maxCoeff(&best);
  EXPECT_EQ(best, 0) << mu.transpose();
  EXPECT_NEAR(filter.estimate().mean(1), a * 200, 0.05);
}

TEST(TwoAxisFilter, AxesAreIndependent) {
  AxisCvImmSpec spec;
  spec.settings.sample_period = 1.0;
  auto two = make_axis_cv_imm_filter(spec);
  ImmAxisFilter x_alone(build_axis_cv_imm(spec)), y_alone(build_axis_cv_imm(spec));
  Eigen::VectorXd mean(4);
  mean << 1.0, 0.1, -2.0, 0.3;
  const Eigen::MatrixXd covariance = Eigen::Vector4d(0.25, 0.5, 0.25, 0.5).asDiagonal();
  two->initialize(mean, covariance);
  GaussianState<2> x0;
  x0.mean = mean.head<2>();
  x0.covariance = covariance.topLeftCorner<2, 2>();
  x_alone.initialize(x0);
  GaussianState<2> y0;
  y0.mean = mean.tail<2>();
  y0.covariance = covariance.bottomRightCorner<2, 2>();
  y_alone.initialize(y0);
  for (int k = 1; k <= 30; ++k) {
    const Eigen::Vector2d z(1.0 + 0.1 * k + 0.2 * std::cos(k), -2.0 + 0.3 * k + 0.01 * k * k);
    ASSERT_EQ(two->step(z), StepStatus::kOk);
    ASSERT_EQ(x_alone.step(z(0)), StepStatus::kOk);
    ASSERT_EQ(y_alone.step(z(1)), StepStatus::kOk);
    // The plot's predictive density is the product of the axes'.
    ASSERT_EQ(two->log_predictive_likelihood(),
              x_alone.log_predictive_likelihood() + y_alone.log_predictive_likelihood());
  }
  Eigen::VectorXd m(4), v(4);
  two->state(m, v);
  EXPECT_EQ(m.head<2>(), x_alone.estimate().mean);
  EXPECT_EQ(two->mode_count(), 6);
  EXPECT_EQ(two->mode_name(4), "y.q0.0001");
  EXPECT_EQ(two->step(Eigen::Vector2d(std::nan(""), 1.0)), StepStatus::kInvalidMeasurement);
}

GaFuzzyImmSpec example_fuzzy_spec() {
  GaFuzzyImmSpec spec;
  spec.settings.sample_period = 1.0;
  spec.levels = {{"u0.001", 0.001, FuzzyRuleTable({{2.33, 0.376, 0.254, 2.591, 0.215e-5}})},
                 {"u0.01", 0.01,
                  FuzzyRuleTable({{0.29, 2.588, -0.311, 3.965, 0.12e-3},
                                  {-0.262, 0.128, -0.007, 0.732, 0.055e-3}})}};
  return spec;
}

TEST(GaFuzzyImmFile, RoundTripKeepsEveryRule) {
  const testing::TempDir dir;
  const auto path = dir / "fuzzy.h5";
  testing::write_model(path, io::kGaFuzzyImmKind, [](io::ModelFileWriter& writer) {
    io::write_ga_fuzzy_imm(writer, example_fuzzy_spec(), {{{"fitness", 0.7}}, {}});
  });
  const GaFuzzyImmSpec back = io::read_ga_fuzzy_imm(path);
  const GaFuzzyImmSpec original = example_fuzzy_spec();
  ASSERT_EQ(back.levels.size(), 2u);
  EXPECT_EQ(back.levels[1].name, "u0.01");
  EXPECT_EQ(back.levels[1].maneuver_level, 0.01);
  EXPECT_EQ(io::rules_matrix(back.levels[1].table), io::rules_matrix(original.levels[1].table));
  EXPECT_EQ(back.settings.transition_stay, 0.97);
  const io::ModelFileReader reader(path);
  EXPECT_EQ(reader.real("/ga_fuzzy_imm/level0", "fitness"), 0.7);
}

// The seed's residual tables are written as version 2 (every reader of version 2 reads them
// right); normalized ones as version 3 with /ga_fuzzy_imm@antecedents and dimensionless inputs.
TEST(GaFuzzyImmFile, NormalizedAntecedentsRoundTripAsVersion3) {
  const testing::TempDir dir;
  auto write = [&](const std::filesystem::path& path, FuzzyAntecedents antecedents) {
    GaFuzzyImmSpec spec = example_fuzzy_spec();
    spec.antecedents = antecedents;
    testing::write_model(path, io::kGaFuzzyImmKind, [&](io::ModelFileWriter& writer) {
      io::write_ga_fuzzy_imm(writer, spec, {});
    });
  };
  write(dir / "residual.h5", FuzzyAntecedents::kResidual);
  write(dir / "normalized.h5", FuzzyAntecedents::kNormalizedInnovation);
  const io::ModelFileReader residual(dir / "residual.h5");
  EXPECT_EQ(residual.schema_version(), io::kBaseModelSchemaVersion);
  EXPECT_FALSE(residual.container().attribute("/ga_fuzzy_imm", "antecedents"));
  EXPECT_EQ(io::read_ga_fuzzy_imm(residual).antecedents, FuzzyAntecedents::kResidual);
  const io::ModelFileReader normalized(dir / "normalized.h5");
  EXPECT_EQ(normalized.schema_version(), 3);
  EXPECT_EQ(normalized.text("/ga_fuzzy_imm", "antecedents"), "normalized_innovation");
  EXPECT_EQ(normalized.text("/ga_fuzzy_imm/level0/rules", "units").substr(0, 8), "1,1,1,1,");
  const GaFuzzyImmSpec back = io::read_ga_fuzzy_imm(normalized);
  EXPECT_EQ(back.antecedents, FuzzyAntecedents::kNormalizedInnovation);
  EXPECT_EQ(io::rules_matrix(back.levels[1].table),
            io::rules_matrix(example_fuzzy_spec().levels[1].table));
}

// A normalized file relabelled as version 2 (an older reader would ignore the attribute and read
// the tables as residual ones), or naming unknown antecedents, is refused naming the field.
TEST(GaFuzzyImmFile, AntecedentsOutsideVersion3OrUnknownAreRefusedNamingTheField) {
  const testing::TempDir dir;
  const auto path = dir / "normalized.h5";
  auto write = [&] {
    io::Provenance provenance;
    provenance.model_kind = std::string(io::kGaFuzzyImmKind);
    io::ModelFileWriter writer(path, provenance);
    GaFuzzyImmSpec spec = example_fuzzy_spec();
    spec.antecedents = FuzzyAntecedents::kNormalizedInnovation;
    io::write_ga_fuzzy_imm(writer, spec, {});
    writer.commit();
  };
  auto refusal = [&] {
    try {
      (void)io::read_ga_fuzzy_imm(path);
    } catch (const io::FileError& error) {
      return std::string(error.what());
    }
    return std::string("read");
  };
  write();
  testing::edit_and_reseal(path, [](hid_t f) {
    const std::int64_t two = 2;
    testing::set_attribute(f, "/", "schema_version", H5T_NATIVE_INT64, &two);
  });
  std::string what = refusal();
  EXPECT_NE(what.find("/ga_fuzzy_imm@antecedents"), std::string::npos) << what;
  EXPECT_NE(what.find("schema version 3"), std::string::npos) << what;
  write();
  testing::edit_and_reseal(path, [](hid_t f) {
    testing::set_text_attribute(f, "/ga_fuzzy_imm", "antecedents", "innovation");
  });
  what = refusal();
  EXPECT_NE(what.find("/ga_fuzzy_imm@antecedents"), std::string::npos) << what;
  EXPECT_NE(what.find("normalized_innovation"), std::string::npos) << what;
}

TEST(GaFuzzyImmFile, InvalidRuleMatrixNamesTheRule) {
  try {
    (void)io::table_from_matrix(
        Eigen::MatrixXd{{0.0, 1.0, 0.0, 1.0, 1e-4}, {0.0, -1.0, 0.0, 1.0, 1e-4}});
    FAIL();
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("rule 1"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace imm
