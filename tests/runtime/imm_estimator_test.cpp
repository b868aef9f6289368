// SPDX-License-Identifier: Apache-2.0
#include "imm/estimation/imm_estimator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <random>

#include "imm/estimation/kalman_mode.hpp"
#include "imm/models/measurement/polar_measurement.hpp"
#include "imm/models/measurement/position_measurement.hpp"
#include "imm/models/motion/constant_acceleration.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/models/motion/singer.hpp"
#include "testing/matrix_checks.hpp"
#include "testing/textbook_imm.hpp"

namespace imm {
namespace {

using Cartesian4 = PositionMeasurement<4, 2>;
using Cartesian6 = PositionMeasurement<6, 2>;

SquareMatrix<2> measurement_covariance() {
  SquareMatrix<2> R;
  R << 0.25, 0.02, 0.02, 0.3;
  return R;
}

Eigen::MatrixXd uniform_transition(int n, double stay) {
  Eigen::MatrixXd pi = Eigen::MatrixXd::Constant(n, n, (1.0 - stay) / (n - 1));
  pi.diagonal().setConstant(stay);
  return pi;
}

GaussianState<4> initial_cv_state() {
  GaussianState<4> state;
  state.mean << 10.0, 0.1, -5.0, 0.2;
  state.covariance = Eigen::Vector4d(0.25, 0.05, 0.25, 0.05).asDiagonal();
  state.covariance(0, 1) = state.covariance(1, 0) = 0.01;
  return state;
}

TEST(ImmEstimator, IdenticalModesEqualASingleKalmanFilter) {
  const auto motion = constant_velocity<2>(1.0, 1e-4);
  const Cartesian4 measurement({0, 2}, measurement_covariance());
  std::vector<std::unique_ptr<ImmMode<4, 2>>> modes;
  modes.reserve(3);
  for (int j = 0; j < 3; ++j) {
    modes.push_back(std::make_unique<KalmanMode<4, 4, Cartesian4>>(
        "m" + std::to_string(j), motion, measurement, StateEmbedding<4, 4>()));
  }
  ImmEstimator<4, 2> imm(std::move(modes), uniform_transition(3, 0.9),
                         Eigen::Vector3d(0.5, 0.3, 0.2));
  imm.initialize(initial_cv_state());
  GaussianState<4> kf = initial_cv_state();

  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.5);
  for (int k = 1; k <= 200; ++k) {
    const Vector<2> z(10.0 + 0.1 * k + noise(rng), -5.0 + 0.2 * k + noise(rng));
    ASSERT_EQ(imm.step(z), StepStatus::kOk);
    kf = predict(kf, motion.transition, motion.process_noise);
    ASSERT_TRUE(update(kf, z, measurement).ok());
    ASSERT_TRUE(testing::matrices_near(imm.estimate().mean, kf.mean, 1e-12)) << "step " << k;
    ASSERT_TRUE(testing::matrices_near(imm.estimate().covariance, kf.covariance, 1e-12));
    // Equal likelihoods: the probabilities only follow the Markov chain towards uniform.
    ASSERT_NEAR(imm.mode_probabilities().sum(), 1.0, 1e-12);
  }
  EXPECT_NEAR(imm.mode_probabilities()(0), 1.0 / 3.0, 1e-9);
}

// A CV mode (4 states, zero-padded), a CA mode and a Singer mode (6 states) against the textbook
// IMM with explicit selection matrices, on a random maneuvering scenario.
TEST(ImmEstimator, MatchesTextbookImplementationWithMixedDimensions) {
  const double T = 1.0;
  const auto cv = constant_velocity<2>(T, 1e-4);
  const auto ca = constant_acceleration<2>(T, 1e-3);
  const auto sg = singer<2>(T, 10.0, 0.05);
  const SquareMatrix<2> R = measurement_covariance();
  const std::array<int, 4> cv_indices{0, 1, 3, 4};

  std::vector<std::unique_ptr<ImmMode<6, 2>>> modes;
  modes.push_back(std::make_unique<KalmanMode<6, 4, Cartesian4>>("cv", cv, Cartesian4({0, 2}, R),
                                                                 StateEmbedding<4, 6>(cv_indices)));
  modes.push_back(std::make_unique<KalmanMode<6, 6, Cartesian6>>("ca", ca, Cartesian6({0, 3}, R),
                                                                 StateEmbedding<6, 6>()));
  modes.push_back(std::make_unique<KalmanMode<6, 6, Cartesian6>>(
      "singer", sg, Cartesian6({0, 3}, R), StateEmbedding<6, 6>()));
  Eigen::Matrix3d pi;
  pi << 0.95, 0.03, 0.02, 0.05, 0.9, 0.05, 0.1, 0.1, 0.8;
  const Eigen::Vector3d mu0(0.6, 0.3, 0.1);
  ImmEstimator<6, 2> imm(std::move(modes), pi, mu0);

  GaussianState<6> initial;
  initial.mean << 1.0, 0.2, 0.0, -2.0, 0.1, 0.0;
  initial.covariance = Eigen::Matrix<double, 6, 1>(0.3, 0.02, 1e-3, 0.3, 0.02, 1e-3).asDiagonal();
  initial.covariance(0, 1) = initial.covariance(1, 0) = 0.01;
  imm.initialize(initial);

  // The textbook modes with explicit matrices.
  Eigen::MatrixXd E_cv = Eigen::MatrixXd::Zero(6, 4);
  for (int i = 0; i < 4; ++i) E_cv(cv_indices[static_cast<std::size_t>(i)], i) = 1.0;
  Eigen::MatrixXd H4 = Eigen::MatrixXd::Zero(2, 4), H6 = Eigen::MatrixXd::Zero(2, 6);
  H4(0, 0) = H4(1, 2) = 1.0;
  H6(0, 0) = H6(1, 3) = 1.0;
  const Eigen::MatrixXd I6 = Eigen::MatrixXd::Identity(6, 6);
  std::vector<testing::TextbookMode> reference_modes = {
      {E_cv, cv.transition, cv.process_noise, H4, R, E_cv.transpose() * initial.mean,
       E_cv.transpose() * initial.covariance * E_cv},
      {I6, ca.transition, ca.process_noise, H6, R, initial.mean, initial.covariance},
      {I6, sg.transition, sg.process_noise, H6, R, initial.mean, initial.covariance}};
  testing::TextbookImm reference(reference_modes, pi, mu0);

  std::mt19937_64 rng(2024);
  std::normal_distribution<double> noise(0.0, 0.5);
  Eigen::Vector2d position(1.0, -2.0), velocity(0.2, 0.1);
  for (int k = 1; k <= 300; ++k) {
    const Eigen::Vector2d acceleration =
        (k > 100 && k < 140) ? Eigen::Vector2d(0.02, -0.01) : Eigen::Vector2d::Zero();
    position += velocity * T + 0.5 * acceleration * T * T;
    velocity += acceleration * T;
    const Vector<2> z(position(0) + noise(rng), position(1) + noise(rng));
    ASSERT_EQ(imm.step(z), StepStatus::kOk);
    reference.step(z);
    ASSERT_TRUE(testing::matrices_near(imm.estimate().mean, reference.mean(), 1e-9))
        << "step " << k;
    ASSERT_TRUE(testing::matrices_near(imm.estimate().covariance, reference.covariance(), 1e-9))
        << "step " << k;
    ASSERT_TRUE(testing::matrices_near(imm.mode_probabilities(), reference.probabilities(), 1e-9))
        << "step " << k;
    // The innovation of the NIS: the moments of the predicted measurement mixture.
    Vector<2> nu;
    SquareMatrix<2> S;
    ASSERT_TRUE(imm.innovation(nu, S));
    ASSERT_TRUE(testing::matrices_near(nu, reference.innovation(), 1e-9)) << "step " << k;
    ASSERT_TRUE(testing::matrices_near(S, reference.innovation_covariance(), 1e-9)) << "step " << k;
    ASSERT_NEAR(imm.log_predictive_likelihood(), std::log(reference.predictive_likelihood()), 1e-9)
        << "step " << k;
  }
}

// log p(z | Z^(k−1)) = log Σ_j c_j N(z; ẑ_j, S_j), by hand for two scalar random-walk modes
// (x(k+1) = x(k) + w_j, z = x + v) on three plots: every number below is the textbook's formula
// written out, with no matrix code.
TEST(ImmEstimator, PredictiveLikelihoodOfTwoModesOnThreePlotsByHand) {
  const double q[2] = {0.01, 1.0}, r = 0.25, stay = 0.9;
  LinearMotionModel<1> walk;
  walk.transition << 1.0;
  std::vector<std::unique_ptr<ImmMode<1, 1>>> modes;
  for (int j = 0; j < 2; ++j) {
    walk.process_noise << q[j];
    SquareMatrix<1> R;
    R << r;
    modes.push_back(std::make_unique<KalmanMode<1, 1, PositionMeasurement<1, 1>>>(
        "m" + std::to_string(j), walk, PositionMeasurement<1, 1>({0}, R), StateEmbedding<1, 1>()));
  }
  Eigen::Matrix2d pi;
  pi << stay, 1.0 - stay, 1.0 - stay, stay;
  ImmEstimator<1, 1> imm(std::move(modes), pi, Eigen::Vector2d(0.7, 0.3));
  GaussianState<1> start;
  start.mean << 0.0;
  start.covariance << 1.0;
  imm.initialize(start);
  EXPECT_TRUE(std::isnan(imm.log_predictive_likelihood()));  // no plot yet

  double mu[2] = {0.7, 0.3}, x[2] = {0.0, 0.0}, P[2] = {1.0, 1.0};
  for (const double z : {0.4, -0.3, 2.5}) {
    double c[2], x0[2], P0[2];
    for (int j = 0; j < 2; ++j) c[j] = pi(0, j) * mu[0] + pi(1, j) * mu[1];
    for (int j = 0; j < 2; ++j) {  // mixing
      const double w0 = pi(0, j) * mu[0] / c[j], w1 = pi(1, j) * mu[1] / c[j];
      x0[j] = w0 * x[0] + w1 * x[1];
      P0[j] = w0 * (P[0] + (x[0] - x0[j]) * (x[0] - x0[j])) +
              w1 * (P[1] + (x[1] - x0[j]) * (x[1] - x0[j]));
    }
    double density = 0.0, joint[2];
    for (int j = 0; j < 2; ++j) {  // mode-matched filters
      const double Pp = P0[j] + q[j], S = Pp + r, nu = z - x0[j];
      joint[j] = c[j] * std::exp(-0.5 * nu * nu / S) / std::sqrt(2.0 * std::numbers::pi * S);
      density += joint[j];
      x[j] = x0[j] + Pp / S * nu;
      P[j] = Pp - Pp * Pp / S;
    }
    for (int j = 0; j < 2; ++j) mu[j] = joint[j] / density;
    ASSERT_EQ(imm.step(Vector<1>(z)), StepStatus::kOk);
    EXPECT_NEAR(imm.log_predictive_likelihood(), std::log(density), 1e-12) << "z " << z;
  }
  ASSERT_EQ(imm.predict_only(), StepStatus::kOk);
  EXPECT_TRUE(std::isnan(imm.log_predictive_likelihood()));  // a prediction scores no plot
}

// The innovation exists only after a successful update: not before the first step, not after a
// prediction without a plot, not after a refused plot.
TEST(ImmEstimator, HasAnInnovationOnlyAfterASuccessfulUpdate) {
  const auto motion = constant_velocity<2>(1.0, 1e-3);
  const Cartesian4 measurement({0, 2}, measurement_covariance());
  std::vector<std::unique_ptr<ImmMode<4, 2>>> modes;
  modes.push_back(std::make_unique<KalmanMode<4, 4, Cartesian4>>("cv", motion, measurement,
                                                                 StateEmbedding<4, 4>()));
  ImmEstimator<4, 2> imm(std::move(modes), Eigen::MatrixXd::Ones(1, 1), Eigen::VectorXd::Ones(1));
  imm.initialize(initial_cv_state());
  Vector<2> nu = Vector<2>::Constant(7.0);
  SquareMatrix<2> S = SquareMatrix<2>::Constant(7.0);
  EXPECT_FALSE(imm.innovation(nu, S));
  EXPECT_EQ(nu(0), 7.0);  // nothing written
  ASSERT_EQ(imm.step(Vector<2>(10.2, -4.7)), StepStatus::kOk);
  ASSERT_TRUE(imm.innovation(nu, S));
  // One mode: the Kalman filter's own ν = z − H F x and S = H (F P Fᵀ + Q) Hᵀ + R, by hand.
  const GaussianState<4> x0 = initial_cv_state();
  const Vector<4> predicted = motion.transition * x0.mean;
  const SquareMatrix<4> P =
      motion.transition * x0.covariance * motion.transition.transpose() + motion.process_noise;
  EXPECT_NEAR(nu(0), 10.2 - predicted(0), 1e-12);
  EXPECT_NEAR(nu(1), -4.7 - predicted(2), 1e-12);
  EXPECT_NEAR(S(0, 0), P(0, 0) + 0.25, 1e-12);
  EXPECT_NEAR(S(0, 1), P(0, 2) + 0.02, 1e-12);
  EXPECT_NEAR(S(1, 1), P(2, 2) + 0.3, 1e-12);
  ASSERT_EQ(imm.predict_only(), StepStatus::kOk);
  EXPECT_FALSE(imm.innovation(nu, S));
  ASSERT_EQ(imm.step(Vector<2>(10.4, -4.5)), StepStatus::kOk);
  EXPECT_TRUE(imm.innovation(nu, S));
  EXPECT_EQ(imm.step(Vector<2>(std::nan(""), 1.0)), StepStatus::kInvalidMeasurement);
  EXPECT_FALSE(imm.innovation(nu, S));
}

// Same comparison for the 4-state, three-level CV IMM (the benchmark filter).
TEST(ImmEstimator, MatchesTextbookImplementationForCvLevels) {
  const double T = 1.0;
  const SquareMatrix<2> R = 0.25 * SquareMatrix<2>::Identity();
  std::vector<std::unique_ptr<ImmMode<4, 2>>> modes;
  modes.reserve(3);
  std::vector<testing::TextbookMode> reference_modes;
  reference_modes.reserve(3);
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(2, 4);
  H(0, 0) = H(1, 2) = 1.0;
  const GaussianState<4> initial = initial_cv_state();
  for (double q : {1e-6, 1e-4, 1e-2}) {
    const auto cv = constant_velocity<2>(T, q);
    modes.push_back(std::make_unique<KalmanMode<4, 4, Cartesian4>>("q", cv, Cartesian4({0, 2}, R),
                                                                   StateEmbedding<4, 4>()));
    reference_modes.push_back({Eigen::MatrixXd::Identity(4, 4), cv.transition, cv.process_noise, H,
                               R, initial.mean, initial.covariance});
  }
  Eigen::Matrix3d pi = Eigen::Matrix3d::Constant(0.015);
  pi.diagonal().setConstant(0.97);
  const Eigen::Vector3d mu0(0.6, 0.2, 0.2);
  ImmEstimator<4, 2> imm(std::move(modes), pi, mu0);
  imm.initialize(initial);
  testing::TextbookImm reference(reference_modes, pi, mu0);
  std::mt19937_64 rng(99);
  std::normal_distribution<double> noise(0.0, 0.5);
  for (int k = 1; k <= 160; ++k) {
    const double ax = (k >= 40 && k < 60) ? 0.01 : 0.0;
    const Vector<2> z(10.0 + 0.1 * k + 0.5 * ax * k * k + noise(rng), -5.0 + 0.2 * k + noise(rng));
    ASSERT_EQ(imm.step(z), StepStatus::kOk);
    reference.step(z);
    ASSERT_TRUE(testing::matrices_near(imm.estimate().mean, reference.mean(), 1e-9));
    ASSERT_TRUE(testing::matrices_near(imm.estimate().covariance, reference.covariance(), 1e-9));
    ASSERT_TRUE(testing::matrices_near(imm.mode_probabilities(), reference.probabilities(), 1e-9));
  }
}

// An outlier 10⁴ σ away: every likelihood is exp(−5·10⁷), zero in double. A linear-space IMM
// divides 0 by 0; in log space the ratio of the modes is still exact.
TEST(ImmEstimator, ModeProbabilitiesSurviveLikelihoodUnderflow) {
  const SquareMatrix<2> R = 0.25 * SquareMatrix<2>::Identity();
  std::vector<std::unique_ptr<ImmMode<4, 2>>> modes;
  std::vector<LinearMotionModel<4>> motions = {constant_velocity<2>(1.0, 1e-6),
                                               constant_velocity<2>(1.0, 1.0)};
  modes.reserve(motions.size());
  for (const auto& motion : motions) {
    modes.push_back(std::make_unique<KalmanMode<4, 4, Cartesian4>>(
        "m", motion, Cartesian4({0, 2}, R), StateEmbedding<4, 4>()));
  }
  const Eigen::Matrix2d pi = uniform_transition(2, 0.9);
  ImmEstimator<4, 2> imm(std::move(modes), pi, Eigen::Vector2d(0.5, 0.5));
  const GaussianState<4> initial = initial_cv_state();
  imm.initialize(initial);
  const Vector<2> z(5000.0, 5000.0);
  ASSERT_EQ(imm.step(z), StepStatus::kOk);

  // Independent: each mode's log-likelihood from its own KF step (mixing keeps identical
  // estimates at the first step), then Bayes in log space by hand.
  double log_post[2];
  for (int j = 0; j < 2; ++j) {
    GaussianState<4> s = predict(initial, motions[static_cast<std::size_t>(j)].transition,
                                 motions[static_cast<std::size_t>(j)].process_noise);
    const auto report = update(s, z, Cartesian4({0, 2}, R));
    ASSERT_TRUE(std::isfinite(report.log_likelihood));
    EXPECT_EQ(std::exp(report.log_likelihood), 0.0);  // underflows in linear space
    log_post[j] = report.log_likelihood + std::log(0.5);
  }
  const double expected_log_mu1 =
      log_post[1] - (std::max(log_post[0], log_post[1]) +
                     std::log1p(std::exp(-std::abs(log_post[0] - log_post[1]))));
  EXPECT_NEAR(imm.log_mode_probabilities()(1), expected_log_mu1, 1e-9);
  EXPECT_TRUE(imm.estimate().all_finite());
  EXPECT_NEAR(imm.mode_probabilities().sum(), 1.0, 1e-12);
}

TEST(ImmEstimator, FailedStepLeavesEverythingUnchanged) {
  const SquareMatrix<2> R = SquareMatrix<2>::Identity();
  std::vector<std::unique_ptr<ImmMode<4, 2>>> modes;
  modes.push_back(std::make_unique<KalmanMode<4, 4, PolarMeasurement<4>>>(
      "a", constant_velocity<2>(1.0, 0.1), PolarMeasurement<4>(0, 2, R), StateEmbedding<4, 4>()));
  modes.push_back(std::make_unique<KalmanMode<4, 4, PolarMeasurement<4>>>(
      "b", constant_velocity<2>(1.0, 1.0), PolarMeasurement<4>(0, 2, R), StateEmbedding<4, 4>()));
  ImmEstimator<4, 2> imm(std::move(modes), uniform_transition(2, 0.9), Eigen::Vector2d(0.7, 0.3));
  GaussianState<4> start;
  start.mean << 100.0, 1.0, 100.0, 1.0;
  imm.initialize(start);
  ASSERT_EQ(imm.step(Vector<2>(std::hypot(101.0, 101.0), std::atan2(101.0, 101.0))),
            StepStatus::kOk);
  const GaussianState<4> before = imm.estimate();
  const ModeVector mu_before = imm.log_mode_probabilities();

  EXPECT_EQ(imm.step(Vector<2>(std::nan(""), 0.1)), StepStatus::kInvalidMeasurement);
  EXPECT_EQ(imm.step(Vector<2>(10.0, std::numeric_limits<double>::infinity())),
            StepStatus::kInvalidMeasurement);
  EXPECT_EQ(imm.estimate().mean, before.mean);
  EXPECT_EQ(imm.estimate().covariance, before.covariance);
  EXPECT_EQ(imm.log_mode_probabilities(), mu_before);

  // Every mode predicts onto the origin: the polar measurement is undefined there.
  GaussianState<4> at_origin;
  at_origin.mean << -1.0, 1.0, -1.0, 1.0;
  imm.initialize(at_origin);
  const GaussianState<4> before_origin = imm.estimate();
  EXPECT_EQ(imm.step(Vector<2>(1.0, 0.0)), StepStatus::kUndefinedMeasurement);
  EXPECT_EQ(imm.estimate().mean, before_origin.mean);
  EXPECT_EQ(imm.estimate().covariance, before_origin.covariance);
}

TEST(ImmEstimator, PredictOnlyPropagatesTheMarkovChain) {
  const Cartesian4 measurement({0, 2}, SquareMatrix<2>::Identity());
  std::vector<std::unique_ptr<ImmMode<4, 2>>> modes;
  for (double q : {0.01, 1.0}) {
    modes.push_back(std::make_unique<KalmanMode<4, 4, Cartesian4>>(
        "m", constant_velocity<2>(1.0, q), measurement, StateEmbedding<4, 4>()));
  }
  Eigen::Matrix2d pi;
  pi << 0.9, 0.1, 0.3, 0.7;
  ImmEstimator<4, 2> imm(std::move(modes), pi, Eigen::Vector2d(1.0, 0.0));
  imm.initialize(initial_cv_state());
  ASSERT_EQ(imm.predict_only(), StepStatus::kOk);
  EXPECT_NEAR(imm.mode_probabilities()(0), 0.9, 1e-15);
  ASSERT_EQ(imm.predict_only(), StepStatus::kOk);
  EXPECT_NEAR(imm.mode_probabilities()(0), 0.9 * 0.9 + 0.1 * 0.3, 1e-15);
  // The mean moves with the CV model: x += v.
  EXPECT_NEAR(imm.estimate().mean(0), 10.0 + 2 * 0.1, 1e-12);
}

TEST(ImmEstimator, ZeroTransitionEntriesStayExactlyZero) {
  const Cartesian4 measurement({0, 2}, SquareMatrix<2>::Identity());
  std::vector<std::unique_ptr<ImmMode<4, 2>>> modes;
  for (double q : {0.01, 1.0}) {
    modes.push_back(std::make_unique<KalmanMode<4, 4, Cartesian4>>(
        "m", constant_velocity<2>(1.0, q), measurement, StateEmbedding<4, 4>()));
  }
  ImmEstimator<4, 2> imm(std::move(modes), Eigen::Matrix2d::Identity(), Eigen::Vector2d(1.0, 0.0));
  imm.initialize(initial_cv_state());
  for (int k = 0; k < 10; ++k) ASSERT_EQ(imm.step(Vector<2>(10.0 + k, -5.0)), StepStatus::kOk);
  EXPECT_EQ(imm.mode_probabilities()(1), 0.0);
  EXPECT_TRUE(imm.estimate().all_finite());
}

// A mode that no mode moves to and that starts at μ = 0 cannot be reached: c_j = 0, log c_j = −∞.
// Its mixed initial condition is its own estimate (weights δ_ij), so it runs as a Kalman filter
// alone, and its probability stays exactly 0 while the others mix among themselves.
TEST(ImmEstimator, AnUnreachableModeRunsAsAKalmanFilterAloneAtProbabilityZero) {
  const auto quiet = constant_velocity<2>(1.0, 1e-4);
  const auto agile = constant_velocity<2>(1.0, 1e-1);
  const Cartesian4 measurement({0, 2}, measurement_covariance());
  std::vector<std::unique_ptr<ImmMode<4, 2>>> modes;
  modes.push_back(std::make_unique<KalmanMode<4, 4, Cartesian4>>("quiet", quiet, measurement,
                                                                 StateEmbedding<4, 4>()));
  modes.push_back(std::make_unique<KalmanMode<4, 4, Cartesian4>>("agile", agile, measurement,
                                                                 StateEmbedding<4, 4>()));
  modes.push_back(std::make_unique<KalmanMode<4, 4, Cartesian4>>("alone", agile, measurement,
                                                                 StateEmbedding<4, 4>()));
  Eigen::Matrix3d pi;
  pi << 0.9, 0.1, 0.0,  //
      0.2, 0.8, 0.0,    //
      0.3, 0.3, 0.4;
  ImmEstimator<4, 2> imm(std::move(modes), pi, Eigen::Vector3d(0.5, 0.5, 0.0));
  imm.initialize(initial_cv_state());
  GaussianState<4> kf = initial_cv_state();
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, 0.5);
  double most_agile = 0.0, least_agile = 1.0;
  for (int k = 1; k <= 60; ++k) {
    const double turn = k > 20 ? 0.3 * (k - 20) * (k - 20) : 0.0;
    const Vector<2> z(10.0 + 0.1 * k + turn + noise(rng), -5.0 + 0.2 * k + noise(rng));
    ASSERT_EQ(k % 7 == 0 ? imm.predict_only() : imm.step(z), StepStatus::kOk) << k;
    kf = predict(kf, agile.transition, agile.process_noise);
    if (k % 7 != 0) {
      ASSERT_TRUE(update(kf, z, measurement).ok());
    }
    EXPECT_EQ(imm.mode_probabilities()(2), 0.0) << k;
    EXPECT_EQ(imm.log_mode_probabilities()(2), -std::numeric_limits<double>::infinity()) << k;
    Vector<4> mean;
    SquareMatrix<4> covariance;
    imm.mode(2).embedded_estimate(mean, covariance);
    ASSERT_TRUE(testing::matrices_near(mean, kf.mean, 1e-12)) << "step " << k;
    ASSERT_TRUE(testing::matrices_near(covariance, kf.covariance, 1e-12)) << "step " << k;
    most_agile = std::max(most_agile, imm.mode_probabilities()(1));
    least_agile = std::min(least_agile, imm.mode_probabilities()(1));
  }
  // The two reachable modes did mix: the quiet one led on the straight, the agile one in the turn.
  EXPECT_LT(least_agile, 0.2);
  EXPECT_GT(most_agile, 0.8);
  EXPECT_NEAR(imm.mode_probabilities().sum(), 1.0, 1e-12);
}

TEST(ImmEstimator, RejectsInvalidConstruction) {
  using Imm = ImmEstimator<4, 2>;
  auto make_modes = [](int n) {
    std::vector<std::unique_ptr<ImmMode<4, 2>>> modes;
    modes.reserve(static_cast<std::size_t>(n));
    for (int j = 0; j < n; ++j) {
      modes.push_back(std::make_unique<KalmanMode<4, 4, Cartesian4>>(
          "m", constant_velocity<2>(1.0, 0.1), Cartesian4({0, 2}, SquareMatrix<2>::Identity()),
          StateEmbedding<4, 4>()));
    }
    return modes;
  };
  Eigen::Matrix2d bad_row;
  bad_row << 0.9, 0.2, 0.1, 0.9;
  EXPECT_THROW(Imm(make_modes(2), bad_row, Eigen::Vector2d(0.5, 0.5)), std::invalid_argument);
  Eigen::Matrix2d negative;
  negative << 1.1, -0.1, 0.1, 0.9;
  EXPECT_THROW(Imm(make_modes(2), negative, Eigen::Vector2d(0.5, 0.5)), std::invalid_argument);
  EXPECT_THROW(Imm(make_modes(2), uniform_transition(3, 0.9), Eigen::Vector2d(0.5, 0.5)),
               std::invalid_argument);
  EXPECT_THROW(Imm(make_modes(2), uniform_transition(2, 0.9), Eigen::Vector2d(0.6, 0.6)),
               std::invalid_argument);
  EXPECT_THROW(Imm(make_modes(0), Eigen::MatrixXd(0, 0), Eigen::VectorXd(0)),
               std::invalid_argument);
  EXPECT_THROW(Imm(make_modes(kMaxModes + 1), uniform_transition(kMaxModes + 1, 0.5),
                   Eigen::VectorXd::Constant(kMaxModes + 1, 1.0 / (kMaxModes + 1))),
               std::invalid_argument);
  Imm uninitialized(make_modes(2), uniform_transition(2, 0.9), Eigen::Vector2d(0.5, 0.5));
  EXPECT_THROW((void)uninitialized.step(Vector<2>(0.0, 0.0)), std::logic_error);
}

}  // namespace
}  // namespace imm
