// SPDX-License-Identifier: Apache-2.0
// The wIMM's and the FIMM's mode step written once over W lanes (position_kalman_step.hpp,
// fimm_step.hpp, wimm_step.hpp): one lane against the general Kalman functions of
// kalman_filter.hpp (predict, update_with_innovation, iterated_update through the TSK sensor) and
// the polar model, to rounding; eight lanes against eight one-lane steps, to the bit, failing
// lanes included.
#include "filters/position_kalman_step.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <random>

#include "filters/fimm_step.hpp"
#include "filters/wimm_step.hpp"
#include "imm/estimation/kalman_filter.hpp"
#include "imm/models/measurement/polar_measurement.hpp"
#include "imm/models/measurement/tsk_sensor_measurement.hpp"
#include "imm/models/motion/constant_acceleration.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/models/motion/singer.hpp"
#include "testing/matrix_checks.hpp"
#include "testing/tsk_sensors.hpp"

namespace imm {
namespace {

using testing::matrices_near;
using testing::same_bits;

double uniform(std::mt19937_64& rng, double low, double high) {
  return std::uniform_real_distribution<double>(low, high)(rng);
}

// A random symmetric positive definite N × N matrix of scale about `scale`.
template <int N>
SquareMatrix<N> random_covariance(std::mt19937_64& rng, double scale) {
  SquareMatrix<N> A;
  for (int i = 0; i < N; ++i) {
    for (int k = 0; k < N; ++k) A(i, k) = uniform(rng, -1.0, 1.0);
  }
  return scale * (A * A.transpose() + 0.1 * SquareMatrix<N>::Identity());
}

// A random motion of D states per axis: CV, Singer or CA with a random period and noise.
template <int D>
LinearMotionModel<D> random_motion(std::mt19937_64& rng) {
  const double T = uniform(rng, 0.05, 5.0);
  if constexpr (D == 2) {
    return constant_velocity<1>(T, uniform(rng, 0.01, 30.0));
  } else if (uniform(rng, 0.0, 1.0) < 0.5) {
    return singer<1>(T, uniform(rng, 1.0, 60.0), uniform(rng, 0.1, 20.0));
  } else {
    return constant_acceleration<1>(T, uniform(rng, 0.01, 10.0));
  }
}

// The block-diagonal N × N matrix of one axis block.
template <int D>
SquareMatrix<2 * D> two_axes(const SquareMatrix<D>& block) {
  SquareMatrix<2 * D> out = SquareMatrix<2 * D>::Zero();
  out.template topLeftCorner<D, D>() = block;
  out.template bottomRightCorner<D, D>() = block;
  return out;
}

// One lane of a mixed condition, from a Gaussian.
template <int D, int W>
void put(const GaussianState<2 * D>& s, int l, double (&mean)[2 * D][W],
         double (&covariance)[2 * D][2 * D][W]) {
  for (int i = 0; i < 2 * D; ++i) {
    mean[i][l] = s.mean(i);
    for (int k = 0; k < 2 * D; ++k) covariance[i][k][l] = s.covariance(i, k);
  }
}

// A random linearization in lane l: H's two position columns, R, ν, ẑ; now and then a lane that
// must fail (undefined h, a singular S, a NaN innovation).
template <int W>
void random_linearization(std::mt19937_64& rng, int l, bank::Linearization<W>& g) {
  for (auto& row : g.h) {
    for (auto& column : row) column[l] = uniform(rng, -2.0, 2.0);
  }
  const SquareMatrix<2> R = random_covariance<2>(rng, uniform(rng, 0.01, 100.0));
  g.r00[l] = R(0, 0);
  g.r01[l] = R(0, 1);
  g.r11[l] = R(1, 1);
  g.nu0[l] = uniform(rng, -10.0, 10.0);
  g.nu1[l] = uniform(rng, -10.0, 10.0);
  g.z_hat0[l] = g.z_hat1[l] = 0.0;
  g.defined[l] = 1.0;
  const double kind = uniform(rng, 0.0, 1.0);
  if (kind < 0.05) g.defined[l] = 0.0;
  if (kind >= 0.05 && kind < 0.1) {  // H = 0, R = 0: S = 0
    for (auto& row : g.h) {
      for (auto& column : row) column[l] = 0.0;
    }
    g.r00[l] = g.r01[l] = g.r11[l] = 0.0;
  }
  if (kind >= 0.1 && kind < 0.15) g.nu1[l] = std::numeric_limits<double>::quiet_NaN();
}

template <int D>
void expect_one_lane_is_the_general_step(std::uint64_t seed) {
  constexpr int N = 2 * D;
  std::mt19937_64 rng(seed);
  int updated = 0;
  for (int trial = 0; trial < 500; ++trial) {
    const LinearMotionModel<D> motion = random_motion<D>(rng);
    const bank::AxisModel model = bank::axis_model<D>(motion);
    GaussianState<N> mixed;
    for (int i = 0; i < N; ++i) mixed.mean(i) = uniform(rng, -1e3, 1e3);
    mixed.covariance = random_covariance<N>(rng, uniform(rng, 0.1, 1e3));
    double mean[N][1], covariance[N][N][1];
    put<D, 1>(mixed, 0, mean, covariance);
    bank::ModeLanes<D, 1> mode{};
    bank::predict<D, 1>(model, mean, covariance, mode);
    bank::Linearization<1> g{};
    random_linearization<1>(rng, 0, g);
    bank::update_mode<D, 1>(g, mode);

    // The same step from the general functions: F and Q of both axes, the full 2 × N H.
    GaussianState<N> reference =
        predict(mixed, two_axes<D>(motion.transition), two_axes<D>(motion.process_noise));
    Matrix<2, N> H = Matrix<2, N>::Zero();
    for (int m = 0; m < 2; ++m) {
      H(m, 0) = g.h[m][0][0];
      H(m, D) = g.h[m][1][0];
    }
    SquareMatrix<2> R;
    R << g.r00[0], g.r01[0], g.r01[0], g.r11[0];
    Vector<N> x;
    SquareMatrix<N> P;
    for (int i = 0; i < N; ++i) {
      x(i) = mode.x[i][0];
      for (int k = 0; k < N; ++k) P(i, k) = mode.P[i][k][0];
    }
    ASSERT_TRUE(matrices_near(x, reference.mean, 1e-12)) << trial;
    ASSERT_TRUE(matrices_near(P, reference.covariance, 1e-12 * reference.covariance.norm()))
        << trial;
    if (g.defined[0] == 0.0) {
      EXPECT_EQ(bank::status_of(mode.code[0]), StepStatus::kUndefinedMeasurement) << trial;
      continue;
    }
    const UpdateReport<2> report =
        update_with_innovation(reference, Vector<2>(g.nu0[0], g.nu1[0]), H, R);
    ASSERT_EQ(bank::status_of(mode.code[0]), report.status) << trial;
    if (!report.ok()) continue;
    ++updated;
    for (int i = 0; i < N; ++i) {
      x(i) = mode.xu[i][0];
      for (int k = 0; k < N; ++k) P(i, k) = mode.U[i][k][0];
    }
    const double scale = reference.covariance.norm() + P.norm();
    EXPECT_TRUE(matrices_near(x, reference.mean, 1e-9)) << trial;
    EXPECT_TRUE(matrices_near(P, reference.covariance, 1e-9 * scale)) << trial;
    EXPECT_NEAR(mode.log_likelihood[0], report.log_likelihood,
                1e-9 * (1.0 + std::abs(report.log_likelihood)))
        << trial;
    SquareMatrix<2> S;
    S << mode.s[0][0], mode.s[1][0], mode.s[1][0], mode.s[2][0];
    EXPECT_TRUE(
        matrices_near(S, report.innovation_covariance, 1e-12 * report.innovation_covariance.norm()))
        << trial;
  }
  EXPECT_GT(updated, 400);
}

TEST(PositionKalmanStep, OneLaneIsThePredictionAndJosephUpdateOfTheGeneralFunctions) {
  expect_one_lane_is_the_general_step<2>(3);
  expect_one_lane_is_the_general_step<3>(4);
}

// Every output of eight lanes against the same lane run alone.
template <int D>
void expect_same_lane(const bank::ModeLanes<D, 8>& wide, int l, const bank::ModeLanes<D, 1>& one) {
  constexpr int N = 2 * D;
  for (int i = 0; i < N; ++i) {
    EXPECT_TRUE(same_bits(wide.x[i][l], one.x[i][0])) << l;
    EXPECT_TRUE(same_bits(wide.xu[i][l], one.xu[i][0])) << l;
    for (int k = 0; k < N; ++k) {
      EXPECT_TRUE(same_bits(wide.P[i][k][l], one.P[i][k][0])) << l;
      EXPECT_TRUE(same_bits(wide.U[i][k][l], one.U[i][k][0])) << l;
    }
  }
  for (int m = 0; m < 2; ++m) EXPECT_TRUE(same_bits(wide.nu[m][l], one.nu[m][0])) << l;
  for (int m = 0; m < 3; ++m) EXPECT_TRUE(same_bits(wide.s[m][l], one.s[m][0])) << l;
  EXPECT_TRUE(same_bits(wide.log_likelihood[l], one.log_likelihood[0])) << l;
  EXPECT_EQ(wide.code[l], one.code[0]) << l;
}

template <int D>
void expect_eight_lanes_are_eight_steps(std::uint64_t seed) {
  constexpr int N = 2 * D;
  std::mt19937_64 rng(seed);
  std::array<int, 6> codes{};
  for (int trial = 0; trial < 200; ++trial) {
    const bank::AxisModel model = bank::axis_model<D>(random_motion<D>(rng));
    double mean[N][8], covariance[N][N][8];
    bank::Linearization<8> g{};
    for (int l = 0; l < 8; ++l) {
      GaussianState<N> mixed;
      for (int i = 0; i < N; ++i) mixed.mean(i) = uniform(rng, -1e3, 1e3);
      mixed.covariance = random_covariance<N>(rng, uniform(rng, 0.1, 1e3));
      put<D, 8>(mixed, l, mean, covariance);
      random_linearization<8>(rng, l, g);
    }
    bank::ModeLanes<D, 8> wide{};
    bank::predict<D, 8>(model, mean, covariance, wide);
    bank::update_mode<D, 8>(g, wide);
    for (int l = 0; l < 8; ++l) {
      double one_mean[N][1], one_covariance[N][N][1];
      bank::Linearization<1> one_g{};
      for (int i = 0; i < N; ++i) {
        one_mean[i][0] = mean[i][l];
        for (int k = 0; k < N; ++k) one_covariance[i][k][0] = covariance[i][k][l];
      }
      for (int m = 0; m < 2; ++m) {
        for (int c = 0; c < 2; ++c) one_g.h[m][c][0] = g.h[m][c][l];
      }
      one_g.r00[0] = g.r00[l];
      one_g.r01[0] = g.r01[l];
      one_g.r11[0] = g.r11[l];
      one_g.nu0[0] = g.nu0[l];
      one_g.nu1[0] = g.nu1[l];
      one_g.defined[0] = g.defined[l];
      bank::ModeLanes<D, 1> one{};
      bank::predict<D, 1>(model, one_mean, one_covariance, one);
      bank::update_mode<D, 1>(one_g, one);
      expect_same_lane<D>(wide, l, one);
      ++codes[static_cast<std::size_t>(one.code[0])];
    }
    if (::testing::Test::HasFailure()) return;
  }
  EXPECT_GT(codes[0], 0);  // kOk
  EXPECT_GT(codes[2], 0);  // kSingular
  EXPECT_GT(codes[3], 0);  // kNonFinite
  EXPECT_GT(codes[5], 0);  // kUndefined
}

TEST(PositionKalmanStep, EightLanesAreEightOneLaneStepsToTheBit) {
  expect_eight_lanes_are_eight_steps<2>(5);
  expect_eight_lanes_are_eight_steps<3>(6);
}

// A FIMM mode's prediction near the test sensor's box (testing/tsk_sensors.hpp: η from about 1).
GaussianState<6> fimm_prediction(std::mt19937_64& rng) {
  GaussianState<6> s;
  s.mean << uniform(rng, -2.0, 2.0), uniform(rng, -1.0, 1.0), uniform(rng, -0.5, 0.5),
      uniform(rng, 0.5, 6.0), uniform(rng, -1.0, 1.0), uniform(rng, -0.5, 0.5);
  s.covariance = random_covariance<6>(rng, uniform(rng, 0.01, 0.5));
  return s;
}

TEST(FimmStep, OneLaneIsTheIteratedUpdateThroughTheTskSensor) {
  std::mt19937_64 rng(7);
  int compared = 0;
  for (const TNorm t_norm : {TNorm::kProduct, TNorm::kMin}) {
    for (const OutsideBox outside : {OutsideBox::kLinear, OutsideBox::kHold}) {
      const auto sensor =
          std::make_shared<const TskSensorModel>(testing::sensor_like_model(t_norm, outside));
      for (const int iterations : {1, 5}) {
        FimmSpec spec;
        spec.sample_period = 0.1;
        spec.measurement_covariance << 0.25, 0.05, 0.05, 0.3;
        spec.iterations = iterations;
        const fimm::Constants b = fimm::constants_of(spec, sensor.get());
        const TskSensorMeasurement<6> measurement(sensor, {0, 3}, spec.measurement_covariance);
        for (int trial = 0; trial < 100; ++trial) {
          const GaussianState<6> predicted = fimm_prediction(rng);
          const Vector<2> z(uniform(rng, -3.0, 3.0), uniform(rng, 0.0, 8.0));
          fimm::Mode<1> mode{};
          for (int i = 0; i < 6; ++i) {
            mode.x[i][0] = predicted.mean(i);
            for (int k = 0; k < 6; ++k) mode.P[i][k][0] = predicted.covariance(i, k);
          }
          fimm::update<1>(b, z.data(), z.data() + 1, mode);
          GaussianState<6> reference = predicted;
          const UpdateReport<2> report = iterated_update(reference, z, measurement, iterations);
          ASSERT_EQ(bank::status_of(mode.code[0]), report.status) << trial;
          if (!report.ok()) continue;
          ++compared;
          Vector<6> x;
          SquareMatrix<6> P;
          for (int i = 0; i < 6; ++i) {
            x(i) = mode.xu[i][0];
            for (int k = 0; k < 6; ++k) P(i, k) = mode.U[i][k][0];
          }
          // lane_exp against libm's exp in the rules' weights: a few ulp of h, more where the
          // iterations stop on the tolerance's other side — not here, at these tolerances.
          EXPECT_TRUE(matrices_near(x, reference.mean, 1e-9)) << trial;
          EXPECT_TRUE(matrices_near(P, reference.covariance, 1e-9)) << trial;
          EXPECT_NEAR(mode.log_likelihood[0], report.log_likelihood, 1e-8) << trial;
          EXPECT_TRUE(
              matrices_near(Vector<2>(mode.nu[0][0], mode.nu[1][0]), report.innovation, 1e-9))
              << trial;
        }
      }
    }
  }
  EXPECT_GT(compared, 700);
}

TEST(FimmStep, EightLanesAreEightOneLaneUpdatesToTheBit) {
  std::mt19937_64 rng(8);
  const auto sensor = std::make_shared<const TskSensorModel>(
      testing::sensor_like_model(TNorm::kProduct, OutsideBox::kLinear));
  for (const int iterations : {1, 3, 8}) {
    FimmSpec spec;
    spec.sample_period = 0.1;
    spec.measurement_covariance << 0.25, 0.05, 0.05, 0.3;
    spec.iterations = iterations;
    const fimm::Constants b = fimm::constants_of(spec, sensor.get());
    for (int trial = 0; trial < 50; ++trial) {
      fimm::Mode<8> wide{};
      double z0[8], z1[8];
      for (int l = 0; l < 8; ++l) {
        const GaussianState<6> predicted = fimm_prediction(rng);
        for (int i = 0; i < 6; ++i) {
          wide.x[i][l] = predicted.mean(i);
          for (int k = 0; k < 6; ++k) wide.P[i][k][l] = predicted.covariance(i, k);
        }
        z0[l] = uniform(rng, -3.0, 3.0);
        z1[l] = l == 5 && trial % 7 == 0 ? std::numeric_limits<double>::quiet_NaN()
                                         : uniform(rng, 0.0, 8.0);
      }
      fimm::Mode<8> lanes = wide;
      fimm::update<8>(b, z0, z1, lanes);
      for (int l = 0; l < 8; ++l) {
        fimm::Mode<1> one{};
        for (int i = 0; i < 6; ++i) {
          one.x[i][0] = wide.x[i][l];
          for (int k = 0; k < 6; ++k) one.P[i][k][0] = wide.P[i][k][l];
        }
        fimm::update<1>(b, &z0[l], &z1[l], one);
        expect_same_lane<3>(lanes, l, one);
      }
      if (HasFailure()) return;
    }
  }
}

TEST(WimmStep, ALinearizationIsThePolarModelsAndLanesAreOneLaneToTheBit) {
  std::mt19937_64 rng(9);
  WimmSpec spec;
  spec.sample_period = 2.0;
  const wimm::Constants b = wimm::constants_of(spec);
  const PolarMeasurement<6> polar(0, 3, spec.measurement_covariance());
  for (int trial = 0; trial < 200; ++trial) {
    double x[2][8], y[2][8], r[2][8], azimuth[2][8], mu[2][8], theta[8];
    for (int l = 0; l < 8; ++l) {
      for (int j = 0; j < 2; ++j) {
        x[j][l] = uniform(rng, -2e5, 2e5);
        y[j][l] = uniform(rng, -2e5, 2e5);
      }
      mu[0][l] = uniform(rng, 0.0, 1.0);
      mu[1][l] = 1.0 - mu[0][l];
    }
    for (int j = 0; j < 2; ++j) wimm::range_and_azimuth<8>(x[j], y[j], r[j], azimuth[j]);
    wimm::theta_bar<8>(mu, x, y, r, theta);
    for (int l = 0; l < 8; ++l) {
      double one_x[2][1], one_y[2][1], one_r[2][1], one_azimuth[2][1], one_mu[2][1], one_theta[1];
      for (int j = 0; j < 2; ++j) {
        one_x[j][0] = x[j][l];
        one_y[j][0] = y[j][l];
        one_mu[j][0] = mu[j][l];
        wimm::range_and_azimuth<1>(one_x[j], one_y[j], one_r[j], one_azimuth[j]);
        EXPECT_TRUE(same_bits(one_r[j][0], r[j][l]));
        EXPECT_TRUE(same_bits(one_azimuth[j][0], azimuth[j][l]));
      }
      wimm::theta_bar<1>(one_mu, one_x, one_y, one_r, one_theta);
      EXPECT_TRUE(same_bits(one_theta[0], theta[l]));
      // θ̄ is the μ̄-weighted circular mean (eq. 9–11) from libm.
      const double s = mu[0][l] * std::sin(std::atan2(x[0][l], y[0][l])) +
                       mu[1][l] * std::sin(std::atan2(x[1][l], y[1][l]));
      const double c = mu[0][l] * std::cos(std::atan2(x[0][l], y[0][l])) +
                       mu[1][l] * std::cos(std::atan2(x[1][l], y[1][l]));
      EXPECT_NEAR(theta[l], std::atan2(s, c), 1e-12);

      // Mode 1's linearization without fusion: the polar model's h, Jacobian, R and wrapped ν.
      Vector<6> state = Vector<6>::Zero();
      state(0) = x[1][l];
      state(3) = y[1][l];
      const Vector<2> z(uniform(rng, 1e3, 3e5), uniform(rng, -3.2, 3.2));
      bank::Linearization<1> g{};
      wimm::polar_lane<1>(b, false, z(0), z(1), theta[l], x[1][l], y[1][l], r[1][l], azimuth[1][l],
                          g, 0);
      const Matrix<2, 6> H = polar.jacobian(state);
      const Vector<2> nu = polar.residual(z, polar.predict(state));
      EXPECT_NEAR(g.h[0][0][0], H(0, 0), 1e-15);
      EXPECT_NEAR(g.h[0][1][0], H(0, 3), 1e-15);
      EXPECT_NEAR(g.h[1][0][0], H(1, 0), 1e-15 * std::abs(H(1, 0)) + 1e-20);
      EXPECT_NEAR(g.h[1][1][0], H(1, 3), 1e-15 * std::abs(H(1, 3)) + 1e-20);
      EXPECT_NEAR(g.nu0[0], nu(0), 1e-9);
      EXPECT_NEAR(g.nu1[0], nu(1), 1e-14);
      EXPECT_EQ(g.r00[0], polar.covariance()(0, 0));
      EXPECT_EQ(g.r11[0], polar.covariance()(1, 1));
    }
    if (HasFailure()) return;
  }
}

}  // namespace
}  // namespace imm
