// SPDX-License-Identifier: Apache-2.0
// The fuzzy-noise step written once over a number type (fuzzy_noise_step.hpp): its double instance
// against the step assembled from the general Kalman functions and the rule table, to the bit; its
// pack instance against the double one, element by element, within the rounding of its two
// primitives; K steps taken together against K taken alone, to the bit.
#include "imm/filters/fuzzy_noise_step.hpp"

// 64-byte vectors by value in the test (lane_math.hpp says why that is harmless).
#pragma GCC diagnostic ignored "-Wpsabi"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "imm/estimation/kalman_filter.hpp"
#include "imm/filters/fuzzy_noise_filter.hpp"
#include "imm/models/learned/fuzzy_rule_table.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "testing/matrix_checks.hpp"

namespace imm {
namespace {

using testing::same_bits;

// One random axis, table and mixed condition; a plot now and then far from the prediction, and
// now and then an unusable variance.
struct Case {
  double T = 1.0, sigma = 1.0;
  FuzzyAntecedents antecedents = FuzzyAntecedents::kResidual;
  FuzzyRuleTable table;
  GaussianState<2> mixed;
  double z = 0.0, previous = 0.0;
};

Case random_case(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto positive = [&](double low, double high) {
    return low + (high - low) * (0.5 + 0.5 * u(rng));
  };
  Case c;
  c.T = positive(0.05, 5.0);
  c.sigma = positive(0.01, 3.0);
  c.antecedents =
      u(rng) > 0.0 ? FuzzyAntecedents::kResidual : FuzzyAntecedents::kNormalizedInnovation;
  std::vector<FuzzyRule> rules;
  rules.reserve(10);
  const int count = 1 + static_cast<int>(positive(0.0, 9.99));
  for (int r = 0; r < count; ++r) {
    rules.push_back({3.0 * u(rng), positive(0.05, 4.0), 3.0 * u(rng), positive(0.05, 4.0),
                     std::pow(10.0, 3.0 * u(rng))});
  }
  c.table = FuzzyRuleTable(rules);
  const double p00 = positive(0.01, 10.0), p11 = positive(0.01, 10.0);
  const double p01 = 0.9 * u(rng) * std::sqrt(p00 * p11);
  c.mixed.mean << 100.0 * u(rng), 10.0 * u(rng);
  c.mixed.covariance << p00, p01, p01, p11;
  // Mostly near the prediction, sometimes 10⁴ σ away (every rule then underflows).
  c.z = c.mixed.mean(0) + c.mixed.mean(1) * c.T + c.sigma * (u(rng) > 0.9 ? 1e4 : 3.0) * u(rng);
  c.previous = 2.0 * u(rng);
  return c;
}

lanes::AxisEstimate entries(const GaussianState<2>& s) {
  return {s.mean(0), s.mean(1), s.covariance(0, 0), s.covariance(0, 1), s.covariance(1, 1)};
}

TEST(FuzzyNoiseStep, TheDoubleInstanceIsTheKalmanStepOfTheRuleTableToTheBit) {
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 3000; ++trial) {
    const Case c = random_case(rng);
    const double R = c.sigma * c.sigma;
    const lanes::FuzzyNoiseStep<double> step = lanes::fuzzy_noise_step<double>(
        lanes::FuzzyAxisConstants(c.T, R, c.antecedents), lanes::FuzzyTableRules(c.table), c.z,
        c.previous, entries(c.mixed));
    // Eq. (19) from the general functions: F x̂ and F P Fᵀ, the table's q, + q G Gᵀ, the Joseph
    // update of kalman_filter.hpp.
    const SquareMatrix<2> F = cv_axis_transition(c.T), no_noise = SquareMatrix<2>::Zero();
    GaussianState<2> predicted = predict(c.mixed, F, no_noise);
    const double residual = c.z - predicted.mean(0);
    const double antecedent = c.antecedents == FuzzyAntecedents::kResidual
                                  ? residual
                                  : residual / std::sqrt(predicted.covariance(0, 0) + R);
    const double q = c.table.process_noise(antecedent, antecedent - c.previous);
    const Vector<2> G = cv_axis_input_gain(c.T);
    const SquareMatrix<2> GGt = G * G.transpose();  // q times the matrix (Eigen would fold q in)
    predicted.covariance += q * GGt;
    Matrix<1, 2> H;
    H << 1.0, 0.0;
    const auto report = update_with_innovation(predicted, Vector<1>(residual), H,
                                               SquareMatrix<1>(SquareMatrix<1>::Constant(R)));
    ASSERT_TRUE(report.ok()) << trial;
    ASSERT_TRUE(step.usable && step.finite) << trial;
    EXPECT_TRUE(same_bits(step.residual, residual)) << trial;
    EXPECT_TRUE(same_bits(step.antecedent, antecedent)) << trial;
    EXPECT_TRUE(same_bits(step.process_noise, q)) << trial;
    EXPECT_TRUE(same_bits(step.s, report.innovation_covariance(0, 0))) << trial;
    EXPECT_TRUE(
        same_bits(-0.5 * (step.mahalanobis + std::log(step.s) + kLogTwoPi), report.log_likelihood))
        << trial;
    const lanes::AxisEstimate e = step.estimate;
    EXPECT_TRUE(same_bits(e.x0, predicted.mean(0)) && same_bits(e.x1, predicted.mean(1))) << trial;
    EXPECT_TRUE(same_bits(e.p00, predicted.covariance(0, 0)) &&
                same_bits(e.p01, predicted.covariance(0, 1)) &&
                same_bits(e.p01, predicted.covariance(1, 0)) &&
                same_bits(e.p11, predicted.covariance(1, 1)))
        << trial;
  }
}

TEST(FuzzyNoiseStep, EveryPackElementIsTheDoubleInstanceWithinItsPrimitivesRounding) {
  // A pack differs from a double in lane_exp (2 ulp) and 1/σ products: q and everything after it
  // move by rounding only, and the outcome flags do not move.
  std::mt19937_64 rng(12);
  constexpr int kW = kLanePackWidth;
  for (int trial = 0; trial < 500; ++trial) {
    const Case c = random_case(rng);
    const lanes::FuzzyAxisConstants axis(c.T, c.sigma * c.sigma, c.antecedents);
    const lanes::FuzzyLevelConstants level(c.table);  // a pack reads 1/σ
    const lanes::FuzzyTableRules rules(c.table);      // a double reads σ
    LanePack z, previous, x0, x1, p00, p01, p11;
    std::vector<Case> lanes_of_case;
    lanes_of_case.reserve(kW);
    for (int l = 0; l < kW; ++l) {
      Case lane = random_case(rng);  // the axis and table of `c`, the lane's own state and plot
      lane.T = c.T, lane.sigma = c.sigma, lane.antecedents = c.antecedents, lane.table = c.table;
      lanes_of_case.push_back(lane);
      z[l] = lane.z, previous[l] = lane.previous;
      const lanes::AxisEstimate e = entries(lane.mixed);
      x0[l] = e.x0, x1[l] = e.x1, p00[l] = e.p00, p01[l] = e.p01, p11[l] = e.p11;
    }
    const lanes::FuzzyNoiseStep<LanePack> pack =
        lanes::fuzzy_noise_step<LanePack>(axis, level, z, previous, {x0, x1, p00, p01, p11});
    for (int l = 0; l < kW; ++l) {
      const Case& lane = lanes_of_case[static_cast<std::size_t>(l)];
      const lanes::FuzzyNoiseStep<double> one =
          lanes::fuzzy_noise_step<double>(axis, rules, lane.z, lane.previous, entries(lane.mixed));
      // Before the table: the same operations.
      EXPECT_TRUE(same_bits(pack.residual[l], one.residual));
      EXPECT_TRUE(same_bits(pack.antecedent[l], one.antecedent));
      EXPECT_EQ(pack.usable[l] != 0, one.usable);
      EXPECT_EQ(pack.finite[l] != 0, one.finite);
      auto near = [](double a, double b) { return std::abs(a - b) <= 1e-12 * (1.0 + std::abs(b)); };
      EXPECT_TRUE(near(pack.process_noise[l], one.process_noise))
          << pack.process_noise[l] << " " << one.process_noise;
      EXPECT_TRUE(near(pack.s[l], one.s));
      EXPECT_TRUE(near(pack.estimate.x0[l], one.estimate.x0));
      EXPECT_TRUE(near(pack.estimate.x1[l], one.estimate.x1));
      EXPECT_TRUE(near(pack.estimate.p00[l], one.estimate.p00));
      EXPECT_TRUE(near(pack.estimate.p01[l], one.estimate.p01));
      EXPECT_TRUE(near(pack.estimate.p11[l], one.estimate.p11));
      EXPECT_TRUE(near(pack.mahalanobis[l], one.mahalanobis));
    }
  }
}

TEST(FuzzyNoiseStep, StepsTakenTogetherEqualStepsTakenAloneToTheBit) {
  std::mt19937_64 rng(13);
  constexpr int kK = 3;
  for (int trial = 0; trial < 300; ++trial) {
    const Case c = random_case(rng);
    const lanes::FuzzyAxisConstants axis(c.T, c.sigma * c.sigma, c.antecedents);
    const lanes::FuzzyTableRules level(c.table);
    double z[kK], previous[kK];
    lanes::AxisEstimate mixed[kK];
    for (int k = 0; k < kK; ++k) {
      const Case lane = random_case(rng);
      z[k] = lane.z, previous[k] = lane.previous, mixed[k] = entries(lane.mixed);
    }
    lanes::FuzzyNoiseStep<double> together[kK];
    lanes::fuzzy_noise_steps<double, kK>(axis, level, z, previous, mixed, together);
    for (int k = 0; k < kK; ++k) {
      const auto alone = lanes::fuzzy_noise_step<double>(axis, level, z[k], previous[k], mixed[k]);
      EXPECT_TRUE(same_bits(together[k].process_noise, alone.process_noise));
      EXPECT_TRUE(same_bits(together[k].estimate.p01, alone.estimate.p01));
      EXPECT_TRUE(same_bits(together[k].mahalanobis, alone.mahalanobis));
    }
  }
}

TEST(FuzzyNoiseStep, RefusesAnUnusableVarianceAsTheKalmanUpdateDoes) {
  const lanes::FuzzyAxisConstants axis(1.0, 0.25, FuzzyAntecedents::kResidual);
  const FuzzyRuleTable table({{0.0, 1.0, 0.0, 1.0, 0.1}});
  const lanes::FuzzyTableRules level(table);
  // A negative position variance beyond R: S < 0, the innovation is singular.
  const auto singular =
      lanes::fuzzy_noise_step<double>(axis, level, 1.0, 0.0, {0.0, 0.0, -5.0, 0.0, 1.0});
  EXPECT_FALSE(singular.usable);
  // An infinite velocity: the update's estimate is not finite.
  const double inf = std::numeric_limits<double>::infinity();
  const auto infinite =
      lanes::fuzzy_noise_step<double>(axis, level, 1.0, 0.0, {0.0, inf, 1.0, 0.0, 1.0});
  EXPECT_FALSE(infinite.usable && infinite.finite);
  // FuzzyNoiseFilter reports them with its status and leaves the state as it was.
  const FuzzyNoiseFilter filter(FuzzyRuleTable({{0.0, 1.0, 0.0, 1.0, 0.1}}), 1.0, 0.25);
  GaussianState<2> state;
  state.covariance << -5.0, 0.0, 0.0, 1.0;
  const GaussianState<2> before = state;
  EXPECT_EQ(filter.step(state, 0.0, 1.0).status, StepStatus::kSingularInnovation);
  EXPECT_EQ(state.covariance, before.covariance);
}

}  // namespace
}  // namespace imm
