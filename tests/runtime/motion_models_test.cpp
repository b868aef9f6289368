// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "imm/models/motion/constant_acceleration.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/models/motion/singer.hpp"
#include "testing/matrix_checks.hpp"

namespace imm {
namespace {

// Discretizes ẋ = A x + B w, w white of PSD q, by integrating Φ̇ = AΦ and the Lyapunov equation
// Q̇ = AQ + QAᵀ + B q Bᵀ (Q(0) = 0) with classical RK4 — an independent reference for the closed
// forms.
struct Discretized {
  Eigen::MatrixXd F, Q;
};

Discretized integrate_continuous_model(const Eigen::MatrixXd& A, const Eigen::VectorXd& B, double q,
                                       double T, int steps = 20000) {
  const Eigen::Index n = A.rows();
  const Eigen::MatrixXd BqB = q * B * B.transpose();
  auto phi_dot = [&](const Eigen::MatrixXd& phi) -> Eigen::MatrixXd { return A * phi; };
  auto q_dot = [&](const Eigen::MatrixXd& Qm) -> Eigen::MatrixXd {
    return A * Qm + Qm * A.transpose() + BqB;
  };
  Eigen::MatrixXd phi = Eigen::MatrixXd::Identity(n, n);
  Eigen::MatrixXd Qm = Eigen::MatrixXd::Zero(n, n);
  const double h = T / steps;
  for (int s = 0; s < steps; ++s) {
    const Eigen::MatrixXd k1 = phi_dot(phi), l1 = q_dot(Qm);
    const Eigen::MatrixXd k2 = phi_dot(phi + 0.5 * h * k1), l2 = q_dot(Qm + 0.5 * h * l1);
    const Eigen::MatrixXd k3 = phi_dot(phi + 0.5 * h * k2), l3 = q_dot(Qm + 0.5 * h * l2);
    const Eigen::MatrixXd k4 = phi_dot(phi + h * k3), l4 = q_dot(Qm + h * l3);
    phi += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    Qm += h / 6.0 * (l1 + 2.0 * l2 + 2.0 * l3 + l4);
  }
  return {phi, Qm};
}

TEST(ConstantVelocity, PiecewiseNoiseIsQGGt) {
  const double T = 2.0, q = 3.0;
  const auto model = constant_velocity<1>(T, q);
  SquareMatrix<2> expected;
  expected << T * T * T * T / 4.0, T * T * T / 2.0, T * T * T / 2.0, T * T;
  EXPECT_TRUE(testing::matrices_near(model.process_noise, q * expected, 1e-15));
  SquareMatrix<2> F;
  F << 1.0, T, 0.0, 1.0;
  EXPECT_EQ(model.transition, F);
}

TEST(ConstantVelocity, ContinuousNoiseMatchesNumericalIntegration) {
  const double T = 1.5, q = 0.7;
  Eigen::MatrixXd A(2, 2);
  A << 0, 1, 0, 0;
  const auto reference = integrate_continuous_model(A, Eigen::Vector2d(0, 1), q, T);
  const auto model = constant_velocity<1>(T, q, NoiseForm::kContinuous);
  EXPECT_TRUE(testing::matrices_near(model.transition, reference.F, 1e-12));
  EXPECT_TRUE(testing::matrices_near(model.process_noise, reference.Q, 1e-10));
}

TEST(ConstantVelocity, TwoAxesAreBlockDiagonal) {
  const auto model = constant_velocity<2>(1.0, 0.01);
  const auto axis = constant_velocity<1>(1.0, 0.01);
  EXPECT_EQ((model.transition.block<2, 2>(2, 2)), axis.transition);
  EXPECT_EQ((model.process_noise.block<2, 2>(0, 0)), axis.process_noise);
  EXPECT_TRUE((model.process_noise.block<2, 2>(0, 2).isZero()));
}

TEST(ConstantAcceleration, ContinuousNoiseMatchesNumericalIntegration) {
  const double T = 0.8, q = 2.5;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3, 3);
  A(0, 1) = A(1, 2) = 1.0;
  const auto reference = integrate_continuous_model(A, Eigen::Vector3d(0, 0, 1), q, T);
  const auto model = constant_acceleration<1>(T, q, NoiseForm::kContinuous);
  EXPECT_TRUE(testing::matrices_near(model.transition, reference.F, 1e-12));
  EXPECT_TRUE(testing::matrices_near(model.process_noise, reference.Q, 1e-10));
}

TEST(ConstantAcceleration, PiecewiseNoiseIsQGGt) {
  const double T = 0.5, q = 4.0;
  const Vector<3> g(T * T / 2.0, T, 1.0);
  EXPECT_TRUE(testing::matrices_near(constant_acceleration<1>(T, q).process_noise,
                                     q * g * g.transpose(), 1e-15));
}

TEST(MotionModels, RejectInvalidParameters) {
  EXPECT_THROW((void)constant_velocity<2>(0.0, 1.0), std::invalid_argument);
  EXPECT_THROW((void)constant_velocity<2>(1.0, -1.0), std::invalid_argument);
  EXPECT_THROW((void)constant_acceleration<2>(std::nan(""), 1.0), std::invalid_argument);
  EXPECT_THROW((void)singer<2>(1.0, 0.0, 1.0), std::invalid_argument);
  EXPECT_THROW((void)singer<2>(1.0, 20.0, -1.0), std::invalid_argument);
}

// Singer: ȧ = −a/τ + w, PSD 2σ²/τ.
struct SingerCase {
  double T, tau, sigma;
};

void PrintTo(const SingerCase& c, std::ostream* out) {
  *out << "T=" << c.T << " tau=" << c.tau << " sigma=" << c.sigma;
}

class SingerDiscretization : public ::testing::TestWithParam<SingerCase> {};

TEST_P(SingerDiscretization, MatchesNumericalIntegrationOfTheContinuousModel) {
  const auto [T, tau, sigma] = GetParam();
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3, 3);
  A(0, 1) = A(1, 2) = 1.0;
  A(2, 2) = -1.0 / tau;
  const auto reference =
      integrate_continuous_model(A, Eigen::Vector3d(0, 0, 1), 2.0 * sigma * sigma / tau, T);
  const auto model = singer<1>(T, tau, sigma);
  EXPECT_TRUE(testing::matrices_near(model.transition, reference.F, 1e-10));
  // Relative to the largest entry of Q: the small off-diagonal terms are differences.
  const double scale = reference.Q.cwiseAbs().maxCoeff();
  EXPECT_TRUE(testing::matrices_near(model.process_noise / scale, reference.Q / scale, 1e-9));
  EXPECT_TRUE(testing::symmetric_positive_definite(model.process_noise));
}

INSTANTIATE_TEST_SUITE_P(
    Parameters, SingerDiscretization,
    ::testing::Values(SingerCase{2.0, 20.0, 5.0},   // seed 004: αT = 0.1 (series branch)
                      SingerCase{1.0, 1.0, 1.0},    // αT = 1 (closed form)
                      SingerCase{0.1, 60.0, 3.0},   // αT ≈ 0.0017
                      SingerCase{1.0, 2.0, 0.5},    // αT = 0.5, at the branch switch
                      SingerCase{5.0, 0.5, 2.0}));  // αT = 10

TEST(SingerDiscretization, StationaryAccelerationVarianceIsSigmaSquared) {
  // Var a(k+1) = e^{−2T/τ} Var a(k) + Q₃₃ must keep σ² fixed — the seed's τ/4 would not.
  const double T = 2.0, tau = 20.0, sigma = 5.0;
  const auto model = singer<1>(T, tau, sigma);
  const double decay = model.transition(2, 2);
  EXPECT_NEAR(decay * decay * sigma * sigma + model.process_noise(2, 2), sigma * sigma, 1e-12);
}

TEST(SingerDiscretization, LongTimeConstantTendsToConstantAcceleration) {
  // τ → ∞ with the PSD q = 2σ²/τ fixed: Singer → CA with continuous white jerk of PSD q.
  const double T = 1.0, q = 0.3, tau = 1e7;
  const auto singer_model = singer<1>(T, tau, std::sqrt(q * tau / 2.0));
  const auto ca = constant_acceleration<1>(T, q, NoiseForm::kContinuous);
  EXPECT_TRUE(testing::matrices_near(singer_model.transition, ca.transition, 1e-6));
  EXPECT_TRUE(testing::matrices_near(singer_model.process_noise / q, ca.process_noise / q, 1e-6));
}

TEST(SingerDiscretization, ShortTimeConstantTendsToConstantVelocity) {
  // τ → 0 with 2σ²τ = q_cv fixed: the acceleration becomes white noise of PSD q_cv, and the
  // [p, v] block becomes CV with continuous white acceleration.
  const double T = 1.0, q_cv = 0.4, tau = 1e-6;
  const auto singer_model = singer<1>(T, tau, std::sqrt(q_cv / (2.0 * tau)));
  const auto cv = constant_velocity<1>(T, q_cv, NoiseForm::kContinuous);
  const SquareMatrix<2> F_pv = singer_model.transition.block<2, 2>(0, 0);
  const SquareMatrix<2> Q_pv = singer_model.process_noise.block<2, 2>(0, 0);
  EXPECT_TRUE(testing::matrices_near(F_pv, cv.transition, 1e-12));
  EXPECT_TRUE(testing::matrices_near(Q_pv, cv.process_noise, 1e-5));
}

}  // namespace
}  // namespace imm
