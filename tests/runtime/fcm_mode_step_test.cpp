// SPDX-License-Identifier: Apache-2.0
// The FCM-compensated mode's step written once over a number type (fcm_mode_step.hpp): its double
// instance against the step assembled from the general Kalman functions (predict,
// update_with_gain with K_c = K + c (ĝ − K)), to the bit; its pack instance against the double
// one, element by element, to the bit; and the refusals the Kalman update makes.
#include "imm/filters/fcm_mode_step.hpp"

// 64-byte vectors by value in the test (lane_math.hpp says why that is harmless).
#pragma GCC diagnostic ignored "-Wpsabi"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "imm/estimation/kalman_filter.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "testing/matrix_checks.hpp"

namespace imm {
namespace {

using testing::same_bits;

// One random mode, mixed condition, plot and noise membership; a plot now and then far from the
// prediction.
struct Case {
  lanes::FcmModeConstants c;
  GaussianState<2> mixed;
  double z = 0.0, u_noise = 1.0;
};

Case random_case(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto positive = [&](double low, double high) {
    return low + (high - low) * (0.5 + 0.5 * u(rng));
  };
  Case k;
  k.c.T = positive(0.05, 5.0);
  const double sigma = positive(0.01, 30.0), q = std::pow(10.0, 3.0 * u(rng));
  const SquareMatrix<2> Q = cv_axis_noise(k.c.T, q, NoiseForm::kPiecewiseConstant);
  k.c.R = sigma * sigma;
  k.c.q00 = Q(0, 0), k.c.q01 = Q(0, 1), k.c.q10 = Q(1, 0), k.c.q11 = Q(1, 1);
  k.c.gain = u(rng) > -0.5 ? positive(0.0, 1.0) : 0.0;
  k.c.g_hat1 = 2.0 / k.c.T;
  k.c.innovation_scale = u(rng) > 0.0;
  const double p00 = positive(0.01, 100.0), p11 = positive(0.01, 100.0);
  const double p01 = 0.9 * u(rng) * std::sqrt(p00 * p11);
  k.mixed.mean << 1000.0 * u(rng), 30.0 * u(rng);
  k.mixed.covariance << p00, p01, p01, p11;
  k.z = k.mixed.mean(0) + k.mixed.mean(1) * k.c.T + sigma * (u(rng) > 0.9 ? 1e4 : 3.0) * u(rng);
  k.u_noise = positive(0.0, 1.0);
  return k;
}

lanes::AxisEstimate entries(const GaussianState<2>& s) {
  return {s.mean(0), s.mean(1), s.covariance(0, 0), s.covariance(0, 1), s.covariance(1, 1)};
}

TEST(FcmModeStep, TheDoubleInstanceIsTheCompensatedKalmanStepToTheBit) {
  std::mt19937_64 rng(21);
  for (int trial = 0; trial < 3000; ++trial) {
    const Case k = random_case(rng);
    const double compensation = k.c.gain * (1.0 - k.u_noise);
    const lanes::FcmPrediction<double> p = lanes::fcm_predict<double>(k.c, entries(k.mixed), k.z);
    const lanes::FcmUpdate<double> step = lanes::fcm_update<double>(k.c, p, compensation);
    // Seed 003's step from the general functions (fcm_imm.hpp's derivation): the CV prediction,
    // e and S, K_c = K + c (ĝ − K), update_with_gain's Joseph form.
    SquareMatrix<2> Q;  // as cv_axis_noise gives it, Q₀₁ and Q₁₀ rounded apart
    Q << k.c.q00, k.c.q01, k.c.q10, k.c.q11;
    GaussianState<2> state = predict(k.mixed, cv_axis_transition(k.c.T), Q);
    EXPECT_TRUE(same_bits(p.predicted.x0, state.mean(0)) &&
                same_bits(p.predicted.x1, state.mean(1)) &&
                same_bits(p.predicted.p00, state.covariance(0, 0)) &&
                same_bits(p.predicted.p01, state.covariance(0, 1)) &&
                same_bits(p.predicted.p11, state.covariance(1, 1)))
        << trial;
    const double S = state.covariance(0, 0) + k.c.R, e = k.z - state.mean(0);
    EXPECT_TRUE(same_bits(p.s, S) && same_bits(p.error, e)) << trial;
    EXPECT_TRUE(same_bits(p.clustered, k.c.innovation_scale ? e / std::sqrt(S) : e)) << trial;
    const Vector<2> K = state.covariance.col(0) / S;
    const Matrix<2, 1> gain = K + compensation * (Vector<2>(1.0, k.c.g_hat1) - K);
    Matrix<1, 2> H;
    H << 1.0, 0.0;
    const auto report = update_with_gain(state, Vector<1>(e), H,
                                         SquareMatrix<1>(SquareMatrix<1>::Constant(k.c.R)), gain);
    ASSERT_TRUE(report.ok()) << trial;
    ASSERT_TRUE(p.usable && step.factored && step.finite) << trial;
    EXPECT_TRUE(same_bits(step.log_likelihood, report.log_likelihood)) << trial;
    const lanes::AxisEstimate& x = step.updated;
    EXPECT_TRUE(same_bits(x.x0, state.mean(0)) && same_bits(x.x1, state.mean(1))) << trial;
    EXPECT_TRUE(
        same_bits(x.p00, state.covariance(0, 0)) && same_bits(x.p01, state.covariance(0, 1)) &&
        same_bits(x.p01, state.covariance(1, 0)) && same_bits(x.p11, state.covariance(1, 1)))
        << trial;
  }
}

TEST(FcmModeStep, EveryPackElementIsTheDoubleInstanceToTheBit) {
  // Both instances use libm's √ and log, and every other operation is the same IEEE operation.
  std::mt19937_64 rng(22);
  constexpr int kW = kLanePackWidth;
  for (int trial = 0; trial < 500; ++trial) {
    const Case mode = random_case(rng);
    LanePack z, compensation, x0, x1, p00, p01, p11;
    Case lane[kW];
    for (int l = 0; l < kW; ++l) {
      lane[l] = random_case(rng);  // the mode's constants, the lane's own state and plot
      lane[l].c = mode.c;
      z[l] = lane[l].z;
      compensation[l] = mode.c.gain * (1.0 - lane[l].u_noise);
      const lanes::AxisEstimate e = entries(lane[l].mixed);
      x0[l] = e.x0, x1[l] = e.x1, p00[l] = e.p00, p01[l] = e.p01, p11[l] = e.p11;
    }
    const auto p = lanes::fcm_predict<LanePack>(mode.c, {x0, x1, p00, p01, p11}, z);
    const auto pack = lanes::fcm_update<LanePack>(mode.c, p, compensation);
    for (int l = 0; l < kW; ++l) {
      const auto p1 = lanes::fcm_predict<double>(mode.c, entries(lane[l].mixed), lane[l].z);
      const auto one = lanes::fcm_update<double>(mode.c, p1, compensation[l]);
      EXPECT_TRUE(same_bits(p.s[l], p1.s) && same_bits(p.error[l], p1.error) &&
                  same_bits(p.clustered[l], p1.clustered));
      EXPECT_EQ(p.usable[l] != 0, p1.usable);
      EXPECT_EQ(pack.factored[l] != 0, one.factored);
      EXPECT_EQ(pack.finite[l] != 0, one.finite);
      EXPECT_TRUE(same_bits(pack.log_likelihood[l], one.log_likelihood));
      EXPECT_TRUE(same_bits(pack.updated.x0[l], one.updated.x0) &&
                  same_bits(pack.updated.x1[l], one.updated.x1) &&
                  same_bits(pack.updated.p00[l], one.updated.p00) &&
                  same_bits(pack.updated.p01[l], one.updated.p01) &&
                  same_bits(pack.updated.p11[l], one.updated.p11))
          << trial << " lane " << l;
    }
  }
}

TEST(FcmModeStep, TheCompensationIsLambdaTimesTheManoeuvreShareAndZeroWithoutLambda) {
  lanes::FcmModeConstants c;
  c.gain = 0.25;
  EXPECT_EQ(lanes::fcm_compensation(c, 0.5), 0.125);
  EXPECT_EQ(lanes::fcm_compensation(c, 1.0), 0.0);
  // An uncompensated mode: 0 whatever its memberships, as FcmCompensatedMode has always given.
  c.gain = 0.0;
  EXPECT_TRUE(same_bits(lanes::fcm_compensation(c, std::numeric_limits<double>::quiet_NaN()), 0.0));
  const LanePack u = splat<LanePack>(0.3);
  const LanePack zero = lanes::fcm_compensation(c, u);
  for (int l = 0; l < kLanePackWidth; ++l) EXPECT_TRUE(same_bits(zero[l], 0.0));
}

TEST(FcmModeStep, RefusesWhatTheKalmanUpdateRefuses) {
  lanes::FcmModeConstants c;
  c.T = 1.0, c.R = 0.25, c.gain = 0.5, c.g_hat1 = 2.0;
  Matrix<1, 2> H;
  H << 1.0, 0.0;
  const SquareMatrix<1> R = SquareMatrix<1>::Constant(c.R);
  // A negative position variance beyond R: S < 0, the innovation is singular.
  const auto singular = lanes::fcm_predict<double>(c, {0.0, 0.0, -5.0, 0.0, 1.0}, 1.0);
  EXPECT_FALSE(singular.usable);
  EXPECT_FALSE(lanes::fcm_update<double>(c, singular, 0.25).factored);
  // An infinite velocity: S is usable, the update's estimate is not finite.
  const double inf = std::numeric_limits<double>::infinity();
  const auto infinite = lanes::fcm_predict<double>(c, {0.0, inf, 1.0, 0.0, 1.0}, 1.0);
  EXPECT_TRUE(infinite.usable);
  const auto infinite_step = lanes::fcm_update<double>(c, infinite, 0.25);
  EXPECT_TRUE(infinite_step.factored);
  EXPECT_FALSE(infinite_step.finite);
  // A non-finite compensation: K_c is not finite, as update_with_gain refuses it.
  const auto p = lanes::fcm_predict<double>(c, {0.0, 0.0, 1.0, 0.0, 1.0}, 1.0);
  EXPECT_FALSE(lanes::fcm_update<double>(c, p, std::numeric_limits<double>::quiet_NaN()).factored);
  // A negative velocity variance left by the update: refused as GaussianState::usable refuses
  // it, and update_with_gain agrees.
  const auto negative = lanes::fcm_predict<double>(c, {0.0, 0.0, 10.0, 0.0, -3.0}, 1.0);
  const auto negative_step = lanes::fcm_update<double>(c, negative, 0.0);
  GaussianState<2> state;
  state.mean << negative.predicted.x0, negative.predicted.x1;
  state.covariance << negative.predicted.p00, negative.predicted.p01, negative.predicted.p01,
      negative.predicted.p11;
  const Vector<2> K = state.covariance.col(0) / negative.s;
  const auto report = update_with_gain(state, Vector<1>(negative.error), H, R, K);
  EXPECT_EQ(report.status, StepStatus::kNonFiniteResult);
  EXPECT_TRUE(negative_step.factored);
  EXPECT_FALSE(negative_step.finite);
}

}  // namespace
}  // namespace imm
