// SPDX-License-Identifier: Apache-2.0
// The coordinated-turn model against independent references: turns computed by hand (a quarter
// circle, a whole circle), the constant-velocity limit, the small-θ closed forms of the Jacobian's
// ω column, both of its branches against each other at their seam, central finite differences,
// and the process noise written out from Bar-Shalom's Γ.

#include "imm/models/motion/coordinated_turn.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <numbers>

namespace imm {
namespace {

using State = Vector<kCoordinatedTurnDim>;

State state(double x, double vx, double y, double vy, double omega) {
  State s;
  s << x, vx, y, vy, omega;
  return s;
}

// A quarter circle: speed 10 m/s east, ω = π/2 rad/s for T = 1 s ends on the circle of radius
// r = v/ω, at (r, r) from the start, heading north.
TEST(CoordinatedTurn, AQuarterCircleByHand) {
  const double omega = std::numbers::pi / 2.0;
  const double r = 10.0 / omega;
  const State next = coordinated_turn_step(state(100.0, 10.0, -50.0, 0.0, omega), 1.0);
  EXPECT_NEAR(next(0), 100.0 + r, 1e-12);
  EXPECT_NEAR(next(2), -50.0 + r, 1e-12);
  EXPECT_NEAR(next(1), 0.0, 1e-12);
  EXPECT_NEAR(next(3), 10.0, 1e-12);
  EXPECT_EQ(next(4), omega);
  // Clockwise for ω < 0: the mirror image.
  const State mirrored = coordinated_turn_step(state(100.0, 10.0, -50.0, 0.0, -omega), 1.0);
  EXPECT_NEAR(mirrored(2), -50.0 - r, 1e-12);
  EXPECT_NEAR(mirrored(3), -10.0, 1e-12);
}

// A whole circle in eight steps returns to the start with the same velocity; the speed is kept
// at every step.
TEST(CoordinatedTurn, AWholeCircleReturnsToItsStart) {
  const double T = 2.5;
  const double omega = 2.0 * std::numbers::pi / (8 * T);
  State s = state(3.0, -7.0, 4.0, 24.0, omega);
  const State start = s;
  for (int k = 0; k < 8; ++k) {
    s = coordinated_turn_step(s, T);
    EXPECT_NEAR(std::hypot(s(1), s(3)), 25.0, 1e-12);
  }
  EXPECT_NEAR((s - start).norm(), 0.0, 1e-11);
}

// ω = 0 is the constant-velocity motion exactly; near it the step stays on its first-order
// expansion x⁺ = x + T vx − (ωT²/2) vy (no division by a tiny ω, no lost digits).
TEST(CoordinatedTurn, TheConstantVelocityLimitIsExactAndSmooth) {
  const double T = 4.0;
  const State cv = coordinated_turn_step(state(1.0, 2.0, 3.0, 4.0, 0.0), T);
  EXPECT_EQ(cv, state(1.0 + 2.0 * T, 2.0, 3.0 + 4.0 * T, 4.0, 0.0));
  for (const double omega : {1e-300, 1e-200, 1e-15, 1e-10}) {
    SCOPED_TRACE(omega);
    const State s = coordinated_turn_step(state(1.0, 200.0, 3.0, 400.0, omega), T);
    EXPECT_DOUBLE_EQ(s(0), 1.0 + 200.0 * T - 0.5 * omega * T * T * 400.0);
    EXPECT_DOUBLE_EQ(s(2), 3.0 + 400.0 * T + 0.5 * omega * T * T * 200.0);
    EXPECT_TRUE(coordinated_turn_jacobian(s, T).allFinite());
  }
}

// The ω column's coefficients near θ = 0 against their closed forms (Taylor series whose next term
// is below 10⁻¹⁷ of the sum at these θ), to the last bits; and both branches against each other at
// the seam θ = 1/2, where the direct formula has lost at most a few bits.
TEST(CoordinatedTurn, TheJacobiansOmegaColumnKeepsItsDigitsNearZero) {
  const double T = 3.0;
  for (const double theta : {1e-300, 1e-150, 1e-9, 1e-6, 1e-4, -1e-4}) {
    SCOPED_TRACE(theta);
    const TurnCoefficients c = turn_coefficients(theta / T, T);
    const double t2 = theta * theta;
    EXPECT_NEAR(c.da, T * T * theta * (-1.0 / 3.0 + t2 / 30.0), 1e-16 * T * T * std::abs(theta));
    EXPECT_NEAR(c.db, T * T * (0.5 - t2 / 8.0), 1e-16 * T * T);
  }
  for (const double seam : {0.5, -0.5}) {
    const TurnCoefficients below = turn_coefficients(std::nextafter(seam, 0.0) / T, T);
    const TurnCoefficients above = turn_coefficients(seam / T, T);
    EXPECT_NEAR(below.da, above.da, 1e-14 * std::abs(above.da));
    EXPECT_NEAR(below.db, above.db, 1e-14 * std::abs(above.db));
  }
  // Far from zero, the direct formulas in long double.
  const long double theta = 2.0L;
  const TurnCoefficients c = turn_coefficients(2.0 / T, T);
  const long double da = T * T * (theta * std::cos(theta) - std::sin(theta)) / (theta * theta);
  EXPECT_NEAR(c.da, static_cast<double>(da), 1e-15 * std::abs(c.da));
}

// The Jacobian against central finite differences of the step, at states with and without a turn.
TEST(CoordinatedTurn, TheJacobianMatchesFiniteDifferences) {
  const double T = 1.5;
  for (const State& x : {state(10.0, 250.0, -40.0, 30.0, 0.0), state(0.0, 250.0, 0.0, -30.0, 1e-9),
                         state(5.0, -120.0, 7.0, 80.0, 0.05), state(1.0, 300.0, 2.0, 10.0, -0.3),
                         state(-3.0, 20.0, 9.0, -40.0, 1.2)}) {
    SCOPED_TRACE(x.transpose());
    const SquareMatrix<kCoordinatedTurnDim> F = coordinated_turn_jacobian(x, T);
    for (int j = 0; j < kCoordinatedTurnDim; ++j) {
      const double h = j == 4 ? 1e-6 : 1e-4 * std::max(1.0, std::abs(x(j)));
      State up = x, down = x;
      up(j) += h;
      down(j) -= h;
      const State column =
          (coordinated_turn_step(up, T) - coordinated_turn_step(down, T)) / (2 * h);
      for (int i = 0; i < kCoordinatedTurnDim; ++i) {
        EXPECT_NEAR(F(i, j), column(i), 1e-6 * std::max(1.0, std::abs(column(i))))
            << "(" << i << ", " << j << ")";
      }
    }
  }
}

// Q written out from Bar-Shalom's Γ = [[T²/2, 0, 0], [T, 0, 0], [0, T²/2, 0], [0, T, 0], [0, 0, T]]
// as Γ diag(σ_a², σ_a², σ_ω²) Γᵀ, and the continuous form's entries; both symmetric PSD.
TEST(CoordinatedTurn, ProcessNoiseIsBarShalomsGamma) {
  const double T = 5.0, qa = 4.0, qw = 1e-6;
  Matrix<kCoordinatedTurnDim, 3> gamma = Matrix<kCoordinatedTurnDim, 3>::Zero();
  gamma(0, 0) = gamma(2, 1) = T * T / 2.0;
  gamma(1, 0) = gamma(3, 1) = gamma(4, 2) = T;
  const Vector<3> variances(qa, qa, qw);
  const SquareMatrix<kCoordinatedTurnDim> expected =
      gamma * variances.asDiagonal() * gamma.transpose();
  const SquareMatrix<kCoordinatedTurnDim> Q = coordinated_turn_noise(T, qa, qw);
  EXPECT_NEAR((Q - expected).norm(), 0.0, 1e-12 * expected.norm());
  const SquareMatrix<kCoordinatedTurnDim> C =
      coordinated_turn_noise(T, qa, qw, NoiseForm::kContinuous);
  EXPECT_DOUBLE_EQ(C(0, 0), qa * T * T * T / 3.0);
  EXPECT_DOUBLE_EQ(C(0, 1), qa * T * T / 2.0);
  EXPECT_DOUBLE_EQ(C(3, 3), qa * T);
  EXPECT_DOUBLE_EQ(C(4, 4), qw * T);
  EXPECT_EQ(C(0, 2), 0.0);
  for (const auto& M : {Q, C}) {
    EXPECT_EQ(M, M.transpose());
    Eigen::SelfAdjointEigenSolver<SquareMatrix<kCoordinatedTurnDim>> eigen(M);
    EXPECT_GE(eigen.eigenvalues().minCoeff(), -1e-12 * M.norm());
  }
  EXPECT_THROW((void)coordinated_turn_noise(0.0, qa, qw), std::invalid_argument);
  EXPECT_THROW((void)coordinated_turn_noise(T, -1.0, qw), std::invalid_argument);
  EXPECT_THROW((void)coordinated_turn_noise(T, qa, std::nan("")), std::invalid_argument);
}

}  // namespace
}  // namespace imm
