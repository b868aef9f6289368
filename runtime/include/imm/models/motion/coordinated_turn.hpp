// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The nearly-coordinated-turn (CT) model with the turn rate in the state, x = [x, vx, y, vy, ω]
/// (Bar-Shalom, Li & Kirubarajan, *Estimation with Applications to Tracking and Navigation*,
/// Wiley 2001, §11.7.1–11.7.2; the "coordinated turn with unknown turn rate" model).
///
/// Over a period T at a constant turn rate ω the velocity rotates by θ = ωT and the position moves
/// along the arc. With a(ω) = sin(θ)/ω and b(ω) = (1 − cos θ)/ω,
///
///     x⁺ = x + a vx − b vy        vx⁺ = cos θ vx − sin θ vy
///     y⁺ = y + b vx + a vy        vy⁺ = sin θ vx + cos θ vy        ω⁺ = ω
///
/// (counter-clockwise for ω > 0). Written as a = T sinc θ and b = T sin(θ/2) sinc(θ/2) (since
/// 1 − cos θ = 2 sin²(θ/2)), both are exact and free of division by a small ω; at ω = 0 they are
/// T and 0, the constant-velocity motion. The Jacobian's ω column needs
///
///     a′ = da/dω = T² (θ cos θ − sin θ)/θ²,    b′ = db/dω = T² (θ sin θ − (1 − cos θ))/θ²,
///
/// which lose digits to cancellation for small θ; for |θ| < 1/2 they are summed from their Taylor
/// series, (θ cos θ − sin θ)/θ² = Σ_{k≥1} (−1)ᵏ 2k θ^{2k−1}/(2k+1)! and
/// (θ sin θ − 1 + cos θ)/θ² = Σ_{k≥0} (−1)ᵏ (2k+1) θ^{2k}/(2k+2)!, to the last bit.
///
/// Process noise: white linear acceleration on each axis and a white turn-rate acceleration, as
/// for the CV model (imm/models/motion/constant_velocity.hpp) — piecewise constant,
/// Q = diag(σ_a² g gᵀ, σ_a² g gᵀ, σ_ω² T²) with g = [T²/2, T]ᵀ (Bar-Shalom §11.7.2, Γ = blocks of
/// g and T), or the exact discretization of continuous noise of PSD q_a, q_ω linearized about the
/// CV motion: diag(q_a [[T³/3, T²/2], [T²/2, T]] ×2, q_ω T). Both noise levels are in the file's
/// length unit: σ_a² in unit²/s⁴, σ_ω² in rad²/s⁴ (piecewise constant) or unit²/s³, rad²/s³
/// (continuous).

#include <cmath>

#include "imm/core/checks.hpp"
#include "imm/models/motion/motion_model.hpp"

namespace imm {

/// The CT model's state dimension, [x, vx, y, vy, ω].
inline constexpr int kCoordinatedTurnDim = 5;

/// The coefficients of one CT step at turn rate ω over T: a = sin(ωT)/ω, b = (1 − cos ωT)/ω,
/// their derivatives in ω, and sin, cos of θ = ωT.
struct TurnCoefficients {
  double a = 0.0;          ///< sin(θ)/ω: the along-velocity position gain (s)
  double b = 0.0;          ///< (1 − cos θ)/ω: the across-velocity position gain (s)
  double da = 0.0;         ///< da/dω (s²)
  double db = 0.0;         ///< db/dω (s²)
  double sin_theta = 0.0;  ///< sin θ
  double cos_theta = 1.0;  ///< cos θ
};

namespace detail {

/// sin(u)/u, 1 at u = 0 (exact: sin u is accurate to its last bit relative to u, so is the ratio).
[[nodiscard]] inline double sinc(double u) { return u == 0.0 ? 1.0 : std::sin(u) / u; }

/// Terms of the two series below summed for |θ| < 1/2 (u = θ² < 1/4): the tenth term is below
/// 10⁻²⁴ of the first.
inline constexpr int kTurnSeriesTerms = 10;

/// The coefficients c_n (n = 0 …) of P(u) = Σ (−1)^{n+1} 2(n+1) uⁿ/(2n+3)!, so that
/// (θ cos θ − sin θ)/θ² = θ P(θ²), and of R(u) = Σ (−1)ⁿ (2n+1) uⁿ/(2n+2)!, so that
/// (θ sin θ − 1 + cos θ)/θ² = R(θ²).
struct TurnSeries {
  double p[kTurnSeriesTerms]{};  ///< P's coefficients
  double r[kTurnSeriesTerms]{};  ///< R's coefficients
  constexpr TurnSeries() {
    for (int n = 0; n < kTurnSeriesTerms; ++n) {
      double p_term = (n % 2 == 0 ? -1.0 : 1.0) * 2.0 * (n + 1);
      for (int f = 2; f <= 2 * n + 3; ++f) p_term /= f;
      double r_term = (n % 2 == 0 ? 1.0 : -1.0) * (2.0 * n + 1.0);
      for (int f = 2; f <= 2 * n + 2; ++f) r_term /= f;
      p[n] = p_term;
      r[n] = r_term;
    }
  }
};
/// The series' coefficients, computed once at compile time.
inline constexpr TurnSeries kTurnSeries{};

/// Σ c_n uⁿ by Horner's rule.
[[nodiscard]] inline double horner(const double (&c)[kTurnSeriesTerms], double u) {
  double sum = c[kTurnSeriesTerms - 1];
  for (int n = kTurnSeriesTerms - 2; n >= 0; --n) sum = sum * u + c[n];
  return sum;
}

}  // namespace detail

/// The coefficients of a CT step (see the file comment); finite for every finite ω and T > 0.
[[nodiscard]] inline TurnCoefficients turn_coefficients(double omega, double T) {
  const double theta = omega * T;
  const double half = 0.5 * theta;
  const double sin_half = std::sin(half);
  TurnCoefficients c;
  c.sin_theta = std::sin(theta);
  c.cos_theta = std::cos(theta);
  c.a = T * detail::sinc(theta);
  c.b = T * sin_half * detail::sinc(half);
  const double T2 = T * T;
  if (std::abs(theta) < 0.5) {
    const double u = theta * theta;
    c.da = T2 * theta * detail::horner(detail::kTurnSeries.p, u);
    c.db = T2 * detail::horner(detail::kTurnSeries.r, u);
  } else {
    const double theta2 = theta * theta;
    c.da = T2 * (theta * c.cos_theta - c.sin_theta) / theta2;
    c.db = T2 * (theta * c.sin_theta - 2.0 * sin_half * sin_half) / theta2;
  }
  return c;
}

/// f(x): the state after one CT step of period T.
[[nodiscard]] inline Vector<kCoordinatedTurnDim> coordinated_turn_step(
    const Vector<kCoordinatedTurnDim>& x, double T) {
  const TurnCoefficients c = turn_coefficients(x(4), T);
  const double vx = x(1), vy = x(3);
  Vector<kCoordinatedTurnDim> next;
  next << x(0) + c.a * vx - c.b * vy,  //
      c.cos_theta * vx - c.sin_theta * vy, x(2) + c.b * vx + c.a * vy,
      c.sin_theta * vx + c.cos_theta * vy, x(4);
  return next;
}

/// ∂f/∂x at x: the EKF's transition matrix of the CT step.
[[nodiscard]] inline SquareMatrix<kCoordinatedTurnDim> coordinated_turn_jacobian(
    const Vector<kCoordinatedTurnDim>& x, double T) {
  const TurnCoefficients c = turn_coefficients(x(4), T);
  const double vx = x(1), vy = x(3);
  SquareMatrix<kCoordinatedTurnDim> F;
  F << 1.0, c.a, 0.0, -c.b, c.da * vx - c.db * vy,                                      //
      0.0, c.cos_theta, 0.0, -c.sin_theta, -T * (c.sin_theta * vx + c.cos_theta * vy),  //
      0.0, c.b, 1.0, c.a, c.db * vx + c.da * vy,                                        //
      0.0, c.sin_theta, 0.0, c.cos_theta, T * (c.cos_theta * vx - c.sin_theta * vy),    //
      0.0, 0.0, 0.0, 0.0, 1.0;
  return F;
}

/// The CT model's process noise over T (see the file comment): `acceleration_noise` for each
/// position axis, `turn_noise` for ω, in the form `form`.
[[nodiscard]] inline SquareMatrix<kCoordinatedTurnDim> coordinated_turn_noise(
    double T, double acceleration_noise, double turn_noise,
    NoiseForm form = NoiseForm::kPiecewiseConstant) {
  require_positive(T, "sample_period");
  require_non_negative(acceleration_noise, "acceleration_noise");
  require_non_negative(turn_noise, "turn_noise");
  SquareMatrix<kCoordinatedTurnDim> Q = SquareMatrix<kCoordinatedTurnDim>::Zero();
  SquareMatrix<2> axis;
  const double T2 = T * T;
  if (form == NoiseForm::kPiecewiseConstant) {
    const Vector<2> g(0.5 * T2, T);
    axis = acceleration_noise * g * g.transpose();
    Q(4, 4) = turn_noise * T2;
  } else {
    axis << T2 * T / 3.0, T2 / 2.0, T2 / 2.0, T;
    axis *= acceleration_noise;
    Q(4, 4) = turn_noise * T;
  }
  Q.block<2, 2>(0, 0) = axis;
  Q.block<2, 2>(2, 2) = axis;
  return Q;
}

}  // namespace imm
