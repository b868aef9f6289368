// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Angle helpers for polar measurements.

#include <cmath>
#include <limits>
#include <numbers>

namespace imm {

/// Wraps an angle into (−π, π]. Finite input only; NaN and ±Inf come back as NaN.
///
/// The exact remainder r = angle − n·2π (n the nearest integer to angle / 2π, ties to even; 2π
/// as the double 2·π), then −π moved to π. Below |angle| < 6 — every difference of two wrapped
/// angles — n is 0 or ±1 and angle ∓ 2π is exact by Sterbenz's lemma (|angle| ≥ π lies within a
/// factor 2 of 2π), so that case skips libm's remainder (a fifth of the wIMM bank's time) and
/// gives the same bits.
[[nodiscard]] inline double wrap_angle(double angle) {
  constexpr double kPi = std::numbers::pi, kTwoPi = 2.0 * std::numbers::pi;
  if (!std::isfinite(angle)) return std::numeric_limits<double>::quiet_NaN();
  double wrapped = angle;  // n = 0 for |angle| ≤ π (at ±π the tie rounds to the even 0)
  if (std::abs(angle) >= 6.0) {
    wrapped = std::remainder(angle, kTwoPi);  // exact, in [−π, π]
  } else if (angle > kPi) {
    wrapped = angle - kTwoPi;
  } else if (angle < -kPi) {
    wrapped = angle + kTwoPi;
  }
  if (wrapped <= -kPi) wrapped += kTwoPi;
  return wrapped;
}

/// Azimuth of the point (x, y) measured clockwise from the y axis (north): atan2(x, y).
[[nodiscard]] inline double azimuth_of(double x, double y) { return std::atan2(x, y); }

/// α θ_a + (1 − α) θ_b on the circle: θ_b + α·wrap(θ_a − θ_b), wrapped (seed 004 eq. 8). Across the
/// ±π seam (a target due south) this stays near ±π where the linear formula would give ≈ 0.
[[nodiscard]] inline double blend_angles(double theta_a, double theta_b, double alpha) {
  return wrap_angle(theta_b + alpha * wrap_angle(theta_a - theta_b));
}

/// Degrees to radians.
[[nodiscard]] constexpr double degrees_to_radians(double degrees) {
  return degrees * std::numbers::pi / 180.0;
}

/// Radians to degrees.
[[nodiscard]] constexpr double radians_to_degrees(double radians) {
  return radians * 180.0 / std::numbers::pi;
}

}  // namespace imm
