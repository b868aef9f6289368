// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <stdexcept>
#include <vector>

#include "imm/estimation/kalman_filter.hpp"
#include "imm/math/angle.hpp"
#include "imm/models/measurement/polar_measurement.hpp"
#include "imm/models/measurement/position_measurement.hpp"
#include "testing/matrix_checks.hpp"

namespace imm {
namespace {

TEST(Angle, WrapIntoHalfOpenInterval) {
  EXPECT_DOUBLE_EQ(wrap_angle(0.0), 0.0);
  EXPECT_DOUBLE_EQ(wrap_angle(std::numbers::pi), std::numbers::pi);
  EXPECT_DOUBLE_EQ(wrap_angle(-std::numbers::pi), std::numbers::pi);
  EXPECT_NEAR(wrap_angle(3.0 * std::numbers::pi / 2.0), -std::numbers::pi / 2.0, 1e-15);
  EXPECT_NEAR(wrap_angle(-7.0 * std::numbers::pi / 2.0), std::numbers::pi / 2.0, 1e-14);
  EXPECT_NEAR(wrap_angle(100.0), 100.0 - 16.0 * 2.0 * std::numbers::pi, 1e-12);
  EXPECT_TRUE(std::isnan(wrap_angle(std::nan(""))));
}

// The rule the fast path must reproduce: libm's exact remainder, −π moved to π.
double wrapped_by_remainder(double angle) {
  double wrapped = std::remainder(angle, 2.0 * std::numbers::pi);
  if (wrapped <= -std::numbers::pi) wrapped += 2.0 * std::numbers::pi;
  return wrapped;
}

TEST(Angle, WrapGivesTheExactRemaindersBits) {
  std::vector<double> angles = {0.0,
                                -0.0,
                                std::numbers::pi,
                                -std::numbers::pi,
                                2.0 * std::numbers::pi,
                                -2.0 * std::numbers::pi,
                                3.0 * std::numbers::pi,
                                -3.0 * std::numbers::pi,
                                6.0,
                                -6.0,
                                1e-300,
                                1e6,
                                -12.5};
  for (const double a : {std::numbers::pi, 2.0 * std::numbers::pi, 3.0 * std::numbers::pi,
                         6.0}) {  // the neighbours of every edge
    for (const double sign : {1.0, -1.0}) {
      double up = sign * a, down = sign * a;
      for (int i = 0; i < 4; ++i) {
        up = std::nextafter(up, 10.0);
        down = std::nextafter(down, -10.0);
        angles.insert(angles.end(), {up, down});
      }
    }
  }
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> uniform(-7.0, 7.0);
  for (int i = 0; i < 200000; ++i) angles.push_back(uniform(rng));
  for (const double a : angles) {
    ASSERT_EQ(std::bit_cast<std::uint64_t>(wrap_angle(a)),
              std::bit_cast<std::uint64_t>(wrapped_by_remainder(a)))
        << std::hexfloat << a;
  }
}

TEST(Angle, AzimuthIsMeasuredClockwiseFromY) {
  EXPECT_DOUBLE_EQ(azimuth_of(0.0, 1.0), 0.0);                       // north
  EXPECT_DOUBLE_EQ(azimuth_of(1.0, 0.0), std::numbers::pi / 2.0);    // east
  EXPECT_DOUBLE_EQ(azimuth_of(-1.0, 0.0), -std::numbers::pi / 2.0);  // west
  EXPECT_DOUBLE_EQ(azimuth_of(1.0, 1.0), std::numbers::pi / 4.0);    // north-east: 45°
}

TEST(PolarMeasurement, PredictsRangeAndAzimuth) {
  const PolarMeasurement<4> model(0, 2, SquareMatrix<2>::Identity());
  Vector<4> x;
  x << 3.0, 0.0, 4.0, 0.0;
  const Vector<2> z = model.predict(x);
  EXPECT_DOUBLE_EQ(z(0), 5.0);
  EXPECT_DOUBLE_EQ(z(1), std::atan2(3.0, 4.0));
}

TEST(PolarMeasurement, JacobianMatchesFiniteDifferences) {
  const PolarMeasurement<6> model(0, 3, SquareMatrix<2>::Identity());
  for (const auto& [x, y] : {std::pair{1000.0, 2000.0}, std::pair{-5e4, 1e3}, std::pair{3.0, -0.5},
                             std::pair{1e5, -1e5}, std::pair{-0.2, 0.1}}) {
    Vector<6> state;
    state << x, 10.0, 0.5, y, -20.0, 0.1;
    const auto numeric = testing::finite_difference_jacobian<2, 6>(
        [&](const Vector<6>& s) { return model.predict(s); }, state, 1e-7);
    EXPECT_TRUE(testing::matrices_near(model.jacobian(state), numeric, 1e-6))
        << "at (" << x << ", " << y << ")";
  }
}

TEST(PolarMeasurement, AzimuthResidualIsWrapped) {
  const PolarMeasurement<4> model(0, 2, SquareMatrix<2>::Identity());
  // Target just west of south (θ ≈ −π + ε) measured just east of south (θ ≈ π − ε).
  const Vector<2> predicted(100.0, -std::numbers::pi + 0.01);
  const Vector<2> measured(101.0, std::numbers::pi - 0.02);
  const Vector<2> residual = model.residual(measured, predicted);
  EXPECT_DOUBLE_EQ(residual(0), 1.0);
  EXPECT_NEAR(residual(1), -0.03, 1e-12);
}

TEST(PolarMeasurement, UndefinedAtTheOriginIsReportedNotComputed) {
  const PolarMeasurement<4> model(0, 2, SquareMatrix<2>::Identity());
  GaussianState<4> state;
  state.mean.setZero();
  const GaussianState<4> before = state;
  const auto report = update(state, Vector<2>(1.0, 0.3), model);
  EXPECT_EQ(report.status, StepStatus::kUndefinedMeasurement);
  EXPECT_EQ(state.covariance, before.covariance);
}

TEST(PolarMeasurement, RejectsInvalidConstruction) {
  SquareMatrix<2> R;
  R << 1.0, 2.0, 2.0, 1.0;  // indefinite
  EXPECT_THROW(PolarMeasurement<4>(0, 2, R), std::invalid_argument);
  EXPECT_THROW(PolarMeasurement<4>(0, 0, SquareMatrix<2>::Identity()), std::invalid_argument);
  EXPECT_THROW(PolarMeasurement<4>(0, 4, SquareMatrix<2>::Identity()), std::invalid_argument);
}

TEST(PolarMeasurement, ConversionToCartesianIsTheLinearizedTransform) {
  const Vector<2> z(5000.0, degrees_to_radians(30.0));
  SquareMatrix<2> R;
  R << 50.0 * 50.0, 0.0, 0.0, std::pow(degrees_to_radians(0.5), 2);
  const CartesianPlot plot = polar_to_cartesian(z, R);
  EXPECT_NEAR(plot.position(0), 2500.0, 1e-9);
  EXPECT_NEAR(plot.position(1), 5000.0 * std::cos(degrees_to_radians(30.0)), 1e-9);
  const auto J = testing::finite_difference_jacobian<2, 2>(
      [](const Vector<2>& p) { return Vector<2>(p(0) * std::sin(p(1)), p(0) * std::cos(p(1))); }, z,
      1e-8);
  EXPECT_TRUE(testing::matrices_near(plot.covariance, J * R * J.transpose(), 1e-6));
}

TEST(PositionMeasurement, SelectsPositionComponents) {
  const PositionMeasurement<6, 2> model({0, 3}, SquareMatrix<2>::Identity());
  Vector<6> x;
  x << 1, 2, 3, 4, 5, 6;
  EXPECT_EQ(model.predict(x), Vector<2>(1, 4));
  EXPECT_THROW((PositionMeasurement<6, 2>({0, 6}, SquareMatrix<2>::Identity())),
               std::invalid_argument);
}

}  // namespace
}  // namespace imm
