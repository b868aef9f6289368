// SPDX-License-Identifier: Apache-2.0
#include "imm/estimation/kalman_filter.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>

#include "imm/models/measurement/position_measurement.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "testing/matrix_checks.hpp"

namespace imm {
namespace {

// x ~ N(0, 1), F = 1, Q = 1, H = 1, R = 1, z = 3, worked by hand:
//   P⁻ = 2, S = 3, K = 2/3, x⁺ = 0 + 2/3·3 = 2,
//   Joseph P⁺ = (1 − 2/3)²·2 + (2/3)²·1 = 2/9 + 4/9 = 2/3,
//   log N(3; 0, 3) = −½(9/3 + ln 3 + ln 2π).
TEST(KalmanFilter, ScalarStepMatchesHandComputation) {
  GaussianState<1> state;
  state.mean << 0.0;
  state.covariance << 1.0;
  const SquareMatrix<1> F = SquareMatrix<1>::Constant(1.0);
  const SquareMatrix<1> Q = SquareMatrix<1>::Constant(1.0);
  const Matrix<1, 1> H = Matrix<1, 1>::Constant(1.0);
  const SquareMatrix<1> R = SquareMatrix<1>::Constant(1.0);

  GaussianState<1> predicted = predict(state, F, Q);
  EXPECT_DOUBLE_EQ(predicted.covariance(0, 0), 2.0);
  const auto report = update(predicted, Vector<1>(3.0), H, R);
  ASSERT_TRUE(report.ok());
  EXPECT_DOUBLE_EQ(report.innovation(0), 3.0);
  EXPECT_DOUBLE_EQ(report.innovation_covariance(0, 0), 3.0);
  EXPECT_DOUBLE_EQ(predicted.mean(0), 2.0);
  EXPECT_DOUBLE_EQ(predicted.covariance(0, 0), 2.0 / 3.0);
  EXPECT_NEAR(report.log_likelihood,
              -0.5 * (3.0 + std::log(3.0) + std::log(2.0 * std::numbers::pi)), 1e-15);
}

// A position-selecting H is gathered, not multiplied (kalman_filter.hpp): over random states the
// update through PositionMeasurement equals the dense products with H to the bit — mean,
// covariance, innovation covariance and log-likelihood.
TEST(KalmanFilter, ASelectingHGivesTheDenseProductsBits) {
  std::uint64_t seed = 99;
  const auto uniform = [&seed] {
    seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(seed >> 11) * 0x1.0p-53 - 0.5;
  };
  const Eigen::Matrix2d R{{0.3, 0.05}, {0.05, 0.2}};
  const PositionMeasurement<4, 2> model({2, 0}, R);  // z = (y, x): not in state order
  for (int trial = 0; trial < 200; ++trial) {
    GaussianState<4> state;
    Matrix<4, 4> A;
    for (int i = 0; i < 16; ++i) A.data()[i] = uniform();
    state.covariance = A * A.transpose() + 0.1 * SquareMatrix<4>::Identity();
    for (int i = 0; i < 4; ++i) state.mean(i) = 100.0 * uniform();
    const Vector<2> z(50.0 * uniform(), 50.0 * uniform());
    GaussianState<4> gathered = state, dense = state;
    const auto g = update(gathered, z, model);
    const Matrix<2, 4>& H = model.matrix();
    const Vector<2> innovation = z - H * state.mean;
    const auto d = update_with_innovation(dense, innovation, H, R);
    ASSERT_EQ(g.status, StepStatus::kOk);
    ASSERT_EQ(d.status, StepStatus::kOk);
    EXPECT_EQ(gathered.mean, dense.mean) << trial;
    EXPECT_EQ(gathered.covariance, dense.covariance) << trial;
    EXPECT_EQ(g.innovation_covariance, d.innovation_covariance) << trial;
    EXPECT_EQ(g.log_likelihood, d.log_likelihood) << trial;
  }
}

TEST(KalmanFilter, PredictWithInputAddsGainTimesInput) {
  GaussianState<2> state;
  state.mean << 1.0, 2.0;
  const double T = 2.0;
  const auto model = constant_velocity<1>(T, 0.0);
  const auto predicted =
      predict(state, model.transition, model.process_noise, cv_input_gain<1>(T), Vector<1>(0.5));
  // p = 1 + 2·2 + ½·0.5·4 = 6, v = 2 + 0.5·2 = 3
  EXPECT_DOUBLE_EQ(predicted.mean(0), 6.0);
  EXPECT_DOUBLE_EQ(predicted.mean(1), 3.0);
}

// The CV filter with piecewise-constant white acceleration converges to the α–β filter whose
// gains have a closed form in the tracking index λ = σ_w T² / σ_v (Kalata 1984;
// Bar-Shalom, Li & Kirubarajan eq. 6.5.3-18/-19):
//   α = −(λ² + 8λ − (λ + 4)√(λ² + 8λ))/8,  β = (λ² + 4λ − λ√(λ² + 8λ))/4,  K = [α, β/T].
class SteadyStateGain : public ::testing::TestWithParam<std::tuple<double, double, double>> {};

TEST_P(SteadyStateGain, MatchesAlphaBetaClosedForm) {
  const auto [T, q, r] = GetParam();
  const auto model = constant_velocity<1>(T, q);
  const PositionMeasurement<2, 1> measurement({0}, SquareMatrix<1>::Constant(r));
  GaussianState<2> state;
  state.covariance = 1e3 * SquareMatrix<2>::Identity();
  Matrix<2, 1> gain = Matrix<2, 1>::Zero();
  for (int k = 0; k < 5000; ++k) {
    state = predict(state, model.transition, model.process_noise);
    gain = state.covariance.col(0) / (state.covariance(0, 0) + r);
    ASSERT_TRUE(update(state, Vector<1>::Zero(), measurement).ok());
  }
  const double lambda = std::sqrt(q) * T * T / std::sqrt(r);
  const double root = std::sqrt(lambda * lambda + 8.0 * lambda);
  const double alpha = -(lambda * lambda + 8.0 * lambda - (lambda + 4.0) * root) / 8.0;
  const double beta = (lambda * lambda + 4.0 * lambda - lambda * root) / 4.0;
  EXPECT_NEAR(gain(0), alpha, 1e-9 * std::max(1.0, alpha));
  EXPECT_NEAR(gain(1), beta / T, 1e-9 * std::max(1.0, beta / T));
}

INSTANTIATE_TEST_SUITE_P(TrackingIndices, SteadyStateGain,
                         ::testing::Values(std::make_tuple(1.0, 1e-6, 0.25),  // seed 000, λ = 0.002
                                           std::make_tuple(1.0, 1.0, 2500.0),  // seed 001, λ = 0.02
                                           std::make_tuple(2.0, 2.0, 50.0),    // λ ≈ 0.8
                                           std::make_tuple(0.1, 100.0, 1e-4)));  // λ = 10

TEST(KalmanFilter, NanMeasurementIsRejectedAndStateUntouched) {
  GaussianState<2> state;
  state.mean << 1.0, -1.0;
  state.covariance << 2.0, 0.5, 0.5, 1.0;
  const GaussianState<2> before = state;
  const PositionMeasurement<2, 1> measurement({0}, SquareMatrix<1>::Constant(1.0));
  for (double bad :
       {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    const auto report = update(state, Vector<1>::Constant(bad), measurement);
    EXPECT_EQ(report.status, StepStatus::kInvalidMeasurement);
    EXPECT_EQ(state.mean, before.mean);
    EXPECT_EQ(state.covariance, before.covariance);
  }
}

TEST(KalmanFilter, SingularInnovationIsReportedAndStateUntouched) {
  GaussianState<2> state;
  state.covariance.setZero();
  const GaussianState<2> before = state;
  Matrix<1, 2> H;
  H << 1.0, 0.0;
  const auto report = update(state, Vector<1>(1.0), H, SquareMatrix<1>(0.0));
  EXPECT_EQ(report.status, StepStatus::kSingularInnovation);
  EXPECT_EQ(state.covariance, before.covariance);
  EXPECT_EQ(state.mean, before.mean);
}

TEST(KalmanFilter, NonFiniteCovarianceIsReportedAndStateUntouched) {
  GaussianState<2> state;
  state.covariance(1, 1) = std::numeric_limits<double>::infinity();
  const GaussianState<2> before = state;
  Matrix<1, 2> H;
  H << 0.0, 1.0;
  const auto report = update(state, Vector<1>(1.0), H, SquareMatrix<1>(1.0));
  EXPECT_NE(report.status, StepStatus::kOk);
  EXPECT_EQ(state.mean, before.mean);
}

// Joseph form with a deliberately suboptimal gain direction still gives the exact posterior
// covariance of the linear update (I − KH)P(I − KH)ᵀ + K R Kᵀ; for the optimal gain it equals
// the textbook (I − KH)P.
TEST(KalmanFilter, JosephFormEqualsStandardFormForOptimalGain) {
  GaussianState<4> state;
  Eigen::Matrix4d A;
  A << 4, 1, 0.5, 0, 1, 3, 0, 0.2, 0.5, 0, 2, 0.1, 0, 0.2, 0.1, 1;
  state.covariance = A * A.transpose();
  Matrix<2, 4> H;
  H << 1, 0, 0, 0, 0, 0, 1, 0;
  SquareMatrix<2> R;
  R << 0.3, 0.05, 0.05, 0.2;
  const Eigen::Matrix4d P = state.covariance;
  const Eigen::Matrix<double, 4, 2> K = P * H.transpose() * (H * P * H.transpose() + R).inverse();
  const Eigen::Matrix4d standard = (Eigen::Matrix4d::Identity() - K * H) * P;
  ASSERT_TRUE(update(state, Vector<2>(0.3, -0.2), H, R).ok());
  EXPECT_TRUE(testing::matrices_near(state.covariance, standard, 1e-12));
  EXPECT_TRUE(testing::symmetric_positive_definite(state.covariance));
}

}  // namespace
}  // namespace imm
