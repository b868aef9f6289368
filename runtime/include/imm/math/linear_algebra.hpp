// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Fixed-size Eigen aliases used throughout the runtime. Hot paths use these types only, so a
/// filter step never touches the heap.

#include <Eigen/Core>

namespace imm {

/// A fixed-size column vector of N doubles.
template <int N>
using Vector = Eigen::Matrix<double, N, 1>;

/// A fixed-size Rows × Cols matrix of doubles.
template <int Rows, int Cols>
using Matrix = Eigen::Matrix<double, Rows, Cols>;

/// A fixed-size N × N matrix of doubles.
template <int N>
using SquareMatrix = Eigen::Matrix<double, N, N>;

/// Largest number of modes an IMM may have. Mode-indexed quantities (probabilities, the
/// transition matrix) use Eigen's fixed maximum size, so they live inside the filter object.
inline constexpr int kMaxModes = 16;

/// Mode-indexed vector (probabilities), at most kMaxModes entries, stored inline.
using ModeVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxModes, 1>;
/// Mode-indexed matrix (transition probabilities), at most kMaxModes², stored inline.
using ModeMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxModes, kMaxModes>;

/// Replaces A by (A + Aᵀ)/2 in place: removes the rounding asymmetry of covariance products.
/// Plain loops over the strict upper triangle — cheaper for small fixed sizes than an Eigen
/// expression with a transposed operand.
template <int N>
void symmetrize(SquareMatrix<N>& a) {
  for (int i = 0; i < N; ++i) {
    for (int j = i + 1; j < N; ++j) {
      const double mean = 0.5 * (a(i, j) + a(j, i));
      a(i, j) = mean;
      a(j, i) = mean;
    }
  }
}

/// Returns (A + Aᵀ)/2: removes the rounding asymmetry of covariance products.
template <class Derived>
[[nodiscard]] typename Derived::PlainObject symmetrized(const Eigen::MatrixBase<Derived>& a) {
  return (0.5 * (a + a.transpose())).eval();
}

}  // namespace imm
