// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Cartesian position measurement z = H x + v, v ~ N(0, R), H selecting the position components
/// of the state (seed 000 eq. 2 per axis; [x, y] in 2-D).

#include <Eigen/Cholesky>
#include <array>
#include <stdexcept>
#include <string>

#include "imm/core/checks.hpp"
#include "imm/math/linear_algebra.hpp"

namespace imm {

/// A linear measurement of M position components of an N-state: z = H x + v.
template <int N, int M>
class PositionMeasurement {
 public:
  /// The measurement dimension.
  static constexpr int kDim = M;

  /// `position_indices[i]` is the state component measured by z_i.
  PositionMeasurement(const std::array<int, M>& position_indices, const SquareMatrix<M>& R)
      : indices_(position_indices), R_(R) {
    require_measurement_covariance(R, "measurement covariance R");
    H_.setZero();
    for (int i = 0; i < M; ++i) {
      const int index = position_indices[static_cast<std::size_t>(i)];
      if (index < 0 || index >= N) {
        throw std::invalid_argument("position index " + std::to_string(index) +
                                    " outside a state of dimension " + std::to_string(N));
      }
      H_(i, index) = 1.0;
    }
  }

  /// H x: the selected components (the same numbers as the product with H).
  [[nodiscard]] Vector<M> predict(const Vector<N>& x) const {
    Vector<M> z;
    for (int i = 0; i < M; ++i) z(i) = x(indices_[static_cast<std::size_t>(i)]);
    return z;
  }
  /// The state component measured by each z_i: H as a selection, which the Kalman update uses
  /// to gather rows and columns instead of multiplying by H's zeros and ones.
  [[nodiscard]] const std::array<int, M>& selected_indices() const { return indices_; }
  /// H (constant).
  [[nodiscard]] const Matrix<M, N>& jacobian(const Vector<N>& /*x*/) const { return H_; }
  /// z − H x̂⁻.
  [[nodiscard]] Vector<M> residual(const Vector<M>& z, const Vector<M>& predicted) const {
    return z - predicted;
  }
  /// R.
  [[nodiscard]] const SquareMatrix<M>& covariance() const { return R_; }
  /// Always true: a linear measurement is defined everywhere.
  [[nodiscard]] bool defined_at(const Vector<N>& /*x*/) const { return true; }
  /// H.
  [[nodiscard]] const Matrix<M, N>& matrix() const { return H_; }

 private:
  std::array<int, M> indices_;
  Matrix<M, N> H_;
  SquareMatrix<M> R_;
};

}  // namespace imm
