// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Polar radar plot z = [range, azimuth] + v, v ~ N(0, R): range √(x² + y²) and azimuth
/// atan2(x, y), measured clockwise from the y axis (seed 004 eq. 15). The azimuth residual is
/// wrapped into (−π, π], so a target crossing north (θ = ±π boundary at south, 0 at north)
/// produces a small innovation, not a 2π jump.

#include <cmath>
#include <stdexcept>
#include <string>

#include "imm/core/checks.hpp"
#include "imm/math/angle.hpp"
#include "imm/math/linear_algebra.hpp"
#include "imm/models/measurement/position_measurement.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// A range-azimuth measurement of the position at two state indices (azimuth from the y axis,
/// wrapped to (−π, π]).
template <int N>
class PolarMeasurement {
 public:
  /// The measurement dimension: (range, azimuth).
  static constexpr int kDim = 2;
  /// Below this range (in state units) the azimuth and the Jacobian are undefined.
  static constexpr double kMinimumRange = 1e-9;

  /// Position at state indices x_index, y_index; R the (range, azimuth) covariance. Throws
  /// std::invalid_argument for bad indices or an R that is not positive definite.
  PolarMeasurement(int x_index, int y_index, const SquareMatrix<2>& R)
      : x_index_(x_index), y_index_(y_index), R_(R) {
    require_measurement_covariance(R, "measurement covariance R");
    if (x_index < 0 || x_index >= N || y_index < 0 || y_index >= N || x_index == y_index) {
      throw std::invalid_argument("polar measurement position indices (" + std::to_string(x_index) +
                                  ", " + std::to_string(y_index) +
                                  ") invalid for a state of dimension " + std::to_string(N));
    }
  }

  /// h(x): range and azimuth.
  [[nodiscard]] Vector<2> predict(const Vector<N>& state) const {
    const double x = state(x_index_), y = state(y_index_);
    return Vector<2>(std::hypot(x, y), azimuth_of(x, y));
  }

  /// ∂r/∂(x, y) = (x, y)/r; ∂θ/∂(x, y) = (y, −x)/r².
  [[nodiscard]] Matrix<2, N> jacobian(const Vector<N>& state) const {
    const double x = state(x_index_), y = state(y_index_);
    const double r2 = x * x + y * y;
    const double r = std::sqrt(r2);
    Matrix<2, N> H = Matrix<2, N>::Zero();
    H(0, x_index_) = x / r;
    H(0, y_index_) = y / r;
    H(1, x_index_) = y / r2;
    H(1, y_index_) = -x / r2;
    return H;
  }

  /// z − h(x̂⁻), the azimuth wrapped to (−π, π].
  [[nodiscard]] Vector<2> residual(const Vector<2>& z, const Vector<2>& predicted) const {
    return Vector<2>(z(0) - predicted(0), wrap_angle(z(1) - predicted(1)));
  }

  /// R.
  [[nodiscard]] const SquareMatrix<2>& covariance() const { return R_; }

  /// Whether h and its Jacobian are defined (range above kMinimumRange).
  [[nodiscard]] bool defined_at(const Vector<N>& state) const {
    return std::hypot(state(x_index_), state(y_index_)) > kMinimumRange;
  }

 private:
  int x_index_;
  int y_index_;
  SquareMatrix<2> R_;
};

/// A polar plot converted to a Cartesian position with the linearized covariance J R Jᵀ
/// (x = r sin θ, y = r cos θ). Used to initialize tracks from polar plots.
struct IMM_RUNTIME_EXPORT CartesianPlot {
  /// Cartesian position (x, y).
  Vector<2> position;
  /// Its covariance J R Jᵀ.
  SquareMatrix<2> covariance;
};

/// A polar plot z = (r, θ) with covariance R as a Cartesian plot.
[[nodiscard]] inline CartesianPlot polar_to_cartesian(const Vector<2>& z,
                                                      const SquareMatrix<2>& R) {
  const double r = z(0), theta = z(1);
  const double s = std::sin(theta), c = std::cos(theta);
  Matrix<2, 2> J;
  J << s, r * c,  //
      c, -r * s;
  return {Vector<2>(r * s, r * c), symmetrized(J * R * J.transpose())};
}

}  // namespace imm
