// SPDX-License-Identifier: Apache-2.0
// Long-run numerical stability: the Joseph-form update and the IMM's moment matching keep every
// covariance symmetric positive definite even when process and measurement noise differ by 10¹⁶.
// The default suite runs 2·10⁴ steps with a full check every 100 (the textbook update
// P = (I − KH)P fails it at step 5 100 with q = 10⁶, r = 10⁻⁸); make test-long runs 10⁶ steps.

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <memory>
#include <random>

#include "imm/estimation/imm_estimator.hpp"
#include "imm/estimation/kalman_mode.hpp"
#include "imm/models/measurement/position_measurement.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "testing/matrix_checks.hpp"
#include "testing/study.hpp"

namespace imm {
namespace {

int steps() { return testing::quick_or_study(20'000, 1'000'000); }
constexpr int kFullCheckEvery = 100;

struct NoiseRatio {
  double q;  // process-noise variance per step
  double r;  // measurement variance
};

void PrintTo(const NoiseRatio& ratio, std::ostream* out) {
  *out << "q=" << ratio.q << " r=" << ratio.r;
}

class CovarianceStability : public ::testing::TestWithParam<NoiseRatio> {};

TEST_P(CovarianceStability, KalmanCovarianceStaysSymmetricPositiveDefinite) {
  const auto [q, r] = GetParam();
  const auto model = constant_velocity<2>(1.0, q);
  const PositionMeasurement<4, 2> measurement({0, 2}, r * SquareMatrix<2>::Identity());
  GaussianState<4> state;
  state.covariance = 1e2 * SquareMatrix<4>::Identity();
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, std::sqrt(r));
  const int n = steps();
  for (int k = 0; k < n; ++k) {
    state = predict(state, model.transition, model.process_noise);
    const Vector<2> z(noise(rng), noise(rng));
    ASSERT_TRUE(update(state, z, measurement).ok()) << "step " << k;
    ASSERT_EQ(Eigen::LLT<SquareMatrix<4>>(state.covariance).info(), Eigen::Success) << "step " << k;
    if (k % kFullCheckEvery == 0) {
      ASSERT_TRUE(testing::symmetric_positive_definite(state.covariance)) << "step " << k;
    }
  }
}

TEST_P(CovarianceStability, ImmCovarianceStaysSymmetricPositiveDefinite) {
  const auto [q, r] = GetParam();
  const PositionMeasurement<4, 2> measurement({0, 2}, r * SquareMatrix<2>::Identity());
  std::vector<std::unique_ptr<ImmMode<4, 2>>> modes;
  // Three modes spanning four decades around q.
  for (double scale : {1e-2, 1.0, 1e2}) {
    modes.push_back(std::make_unique<KalmanMode<4, 4, PositionMeasurement<4, 2>>>(
        "m", constant_velocity<2>(1.0, q * scale), measurement, StateEmbedding<4, 4>()));
  }
  Eigen::Matrix3d pi = Eigen::Matrix3d::Constant(0.015);
  pi.diagonal().setConstant(0.97);
  ImmEstimator<4, 2> imm(std::move(modes), pi, Eigen::Vector3d(0.6, 0.2, 0.2));
  GaussianState<4> start;
  start.covariance = 1e2 * SquareMatrix<4>::Identity();
  imm.initialize(start);
  std::mt19937_64 rng(12);
  std::normal_distribution<double> noise(0.0, std::sqrt(r));
  const int n = steps();
  for (int k = 0; k < n; ++k) {
    const Vector<2> z(noise(rng), noise(rng));
    ASSERT_EQ(imm.step(z), StepStatus::kOk) << "step " << k;
    ASSERT_EQ(Eigen::LLT<SquareMatrix<4>>(imm.estimate().covariance).info(), Eigen::Success)
        << "step " << k;
    if (k % kFullCheckEvery == 0) {
      ASSERT_TRUE(testing::symmetric_positive_definite(imm.estimate().covariance)) << "step " << k;
      ASSERT_NEAR(imm.mode_probabilities().sum(), 1.0, 1e-12);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(ExtremeRatios, CovarianceStability,
                         ::testing::Values(NoiseRatio{1e-12, 1e4},    // almost deterministic motion
                                           NoiseRatio{1e6, 1e-8},     // almost perfect sensor
                                           NoiseRatio{1e-6, 0.25}));  // seed 000's quiet mode

}  // namespace
}  // namespace imm
