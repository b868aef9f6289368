// SPDX-License-Identifier: Apache-2.0
// The χ² machinery behind the consistency columns, against closed forms and printed tables.
#include "imm/evaluation/consistency.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "imm/datasets/random.hpp"

namespace imm::evaluation {
namespace {

TEST(RegularizedGamma, MatchesTheClosedFormsOfOneAndTwoDegreesOfFreedom) {
  for (double x : {0.0, 1e-8, 0.3, 1.0, 2.5, 7.0, 30.0, 200.0}) {
    // Two degrees of freedom: the χ² CDF is 1 − e^{−x/2} (P(1, x/2)).
    EXPECT_NEAR(regularized_gamma_p(1.0, x / 2.0), 1.0 - std::exp(-x / 2.0), 1e-14) << x;
    // One: erf(√(x/2)) (P(1/2, x/2)).
    EXPECT_NEAR(regularized_gamma_p(0.5, x / 2.0), std::erf(std::sqrt(x / 2.0)), 1e-14) << x;
  }
  EXPECT_THROW((void)regularized_gamma_p(0.0, 1.0), std::invalid_argument);
  EXPECT_THROW((void)regularized_gamma_p(1.0, -1.0), std::invalid_argument);
  EXPECT_THROW((void)regularized_gamma_p(1.0, std::nan("")), std::invalid_argument);
}

TEST(ChiSquareQuantile, MatchesClosedFormsAndPrintedTables) {
  // Two degrees of freedom: −2 ln(1 − p).
  for (double p : {0.001, 0.025, 0.5, 0.975, 0.999}) {
    EXPECT_NEAR(chi_square_quantile(p, 2.0), -2.0 * std::log1p(-p), 1e-10 * (1.0 - std::log1p(-p)))
        << p;
  }
  // Printed tables (Abramowitz & Stegun 26.4; NIST/SEMATECH e-Handbook 1.3.6.7.4).
  EXPECT_NEAR(chi_square_quantile(0.95, 1.0), 3.841458820694124, 1e-9);
  EXPECT_NEAR(chi_square_quantile(0.05, 10.0), 3.940299136119, 1e-8);
  EXPECT_NEAR(chi_square_quantile(0.95, 10.0), 18.307038053275, 1e-8);
  EXPECT_NEAR(chi_square_quantile(0.025, 100.0), 74.2219, 1e-4);
  EXPECT_NEAR(chi_square_quantile(0.975, 100.0), 129.5612, 1e-4);
  EXPECT_NEAR(chi_square_quantile(0.025, 200.0), 162.728, 1e-3);
  EXPECT_NEAR(chi_square_quantile(0.975, 200.0), 241.058, 1e-3);
  // Very many degrees of freedom (100 runs × 2 × 300 scans): Wilson–Hilferty is exact to ~1e-7
  // relative there.
  const double k = 60000.0, z = 1.959963984540054;
  const double wilson_hilferty =
      k * std::pow(1.0 - 2.0 / (9.0 * k) + z * std::sqrt(2.0 / (9.0 * k)), 3);
  EXPECT_NEAR(chi_square_quantile(0.975, k) / wilson_hilferty, 1.0, 1e-6);
  EXPECT_THROW((void)chi_square_quantile(0.0, 2.0), std::invalid_argument);
  EXPECT_THROW((void)chi_square_quantile(1.0, 2.0), std::invalid_argument);
  EXPECT_THROW((void)chi_square_quantile(0.5, 0.0), std::invalid_argument);
}

// Bar-Shalom, Li & Kirubarajan §5.4.2: 50 runs of a 2-state NEES give [74.22, 129.56] / 50.
TEST(ConsistencyBounds, AreTheTextbooksTwoSidedInterval) {
  const ConsistencyBounds b = average_bounds(2, 50);
  EXPECT_NEAR(b.lower, 74.2219 / 50.0, 1e-5);
  EXPECT_NEAR(b.upper, 129.5612 / 50.0, 1e-5);
  EXPECT_STREQ(b.verdict(2.0), "consistent");
  EXPECT_STREQ(b.verdict(2.7), "optimistic");
  EXPECT_STREQ(b.verdict(1.4), "pessimistic");
  EXPECT_THROW((void)average_bounds(0, 50), std::invalid_argument);
  EXPECT_THROW((void)average_bounds(2, 0), std::invalid_argument);
}

// What the bounds promise: the average NEES of a consistent estimator (errors drawn from its own
// covariance) falls inside them 95 % of the time.
TEST(ConsistencyBounds, HoldTheAverageOfAConsistentEstimatorNinetyFivePercentOfTheTime) {
  datasets::Rng rng(2024);
  const int dimension = 2, runs = 30, trials = 4000;
  const ConsistencyBounds b = average_bounds(dimension, runs);
  int inside = 0;
  for (int t = 0; t < trials; ++t) {
    double sum = 0.0;
    for (int r = 0; r < runs; ++r) {
      for (int d = 0; d < dimension; ++d) {
        const double e = rng.normal(0.0, 1.0);
        sum += e * e;
      }
    }
    inside += b.verdict(sum / runs) == std::string("consistent") ? 1 : 0;
  }
  // Binomial(4000, 0.95): standard deviation 0.0034; four of them.
  EXPECT_NEAR(static_cast<double>(inside) / trials, 0.95, 4 * 0.0034);
}

// The summary of a planted evaluation: runs × scans NEES drawn from χ²₂ scaled by `scale` (1: a
// consistent filter; 3: its covariance a third of its errors'; 0.4: too large).
Eigen::MatrixXd planted_nees(double scale, std::uint64_t seed) {
  datasets::Rng rng(seed);
  Eigen::MatrixXd nees(40, 200);
  for (Eigen::Index r = 0; r < nees.rows(); ++r) {
    for (Eigen::Index k = 0; k < nees.cols(); ++k) {
      const double a = rng.normal(0.0, 1.0), b = rng.normal(0.0, 1.0);
      nees(r, k) = scale * (a * a + b * b);
    }
  }
  nees(3, 5) = std::nan("");  // a run without an estimate at that scan
  return nees;
}

TEST(PositionConsistency, NamesAConsistentAnOptimisticAndAPessimisticFilter) {
  const ConsistencySummary consistent = summarize_consistency(planted_nees(1.0, 1), 2);
  EXPECT_NEAR(consistent.average, 2.0, 0.05);
  EXPECT_NEAR(consistent.inside, 0.95, 0.04);
  EXPECT_EQ(consistent.scans, 200);
  EXPECT_STREQ(consistent.verdict(), "consistent");
  const ConsistencySummary optimistic = summarize_consistency(planted_nees(3.0, 2), 2);
  EXPECT_GT(optimistic.above, 0.99);
  EXPECT_STREQ(optimistic.verdict(), "optimistic");
  const ConsistencySummary pessimistic = summarize_consistency(planted_nees(0.4, 3), 2);
  EXPECT_LT(pessimistic.inside, 0.01);
  EXPECT_EQ(pessimistic.above, 0.0);
  EXPECT_STREQ(pessimistic.verdict(), "pessimistic");
  EXPECT_EQ(summarize_consistency(Eigen::MatrixXd(0, 0), 2).scans, 0);
}

// The regression gate's consistency error: |ln(ANEES / 2)| per run, 0 for a consistent filter up
// to its sampling error (a run's ANEES over 200 scans of χ²₂ / 2 has a standard deviation of
// 1/√200 ≈ 0.071), ln 3 with the covariance a third of the errors', |ln 0.4| with it too large.
TEST(PositionConsistency, TheLogRatioMeasuresHowFarEachRunIsFromConsistent) {
  const Eigen::VectorXd consistent = nees_log_ratio(planted_nees(1.0, 1), 2);
  ASSERT_EQ(consistent.size(), 40);
  EXPECT_LT(consistent.mean(), 4 * 0.071);
  EXPECT_NEAR(nees_log_ratio(planted_nees(3.0, 2), 2).mean(), std::log(3.0), 4 * 0.071 / 3);
  EXPECT_NEAR(nees_log_ratio(planted_nees(0.4, 3), 2).mean(), -std::log(0.4), 4 * 0.071);
  Eigen::MatrixXd none = Eigen::MatrixXd::Constant(2, 3, std::nan(""));
  none(1, 2) = 6.0;  // one scan: ANEES 6 against 2
  const Eigen::VectorXd sparse = nees_log_ratio(none, 2);
  EXPECT_EQ(sparse(0), 0.0);
  EXPECT_NEAR(sparse(1), std::log(3.0), 1e-15);
}

}  // namespace
}  // namespace imm::evaluation
