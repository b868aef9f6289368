#pragma once
/// Fixed-size Eigen aliases used throughout the runtime. Hot paths use these types only, so a
/// filter step never touches the heap.

#include <Eigen/Core>

namespace imm {

template <int N>
using Vector = Eigen::Matrix<double, N, 1>;

template <int Rows, int Cols>
using Matrix = Eigen::Matrix<double, Rows, Cols>;

template <int N>
using SquareMatrix = Eigen::Matrix<double, N, N>;

/// Largest number of modes an IMM may have. Mode-indexed quantities (probabilities, the
/// transition matrix) use Eigen's fixed maximum size, so they live inside the filter object.
inline constexpr int kMaxModes = 16;

using ModeVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxModes, 1>;
using ModeMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxModes, kMaxModes>;

/// Returns (A + Aᵀ)/2: removes the rounding asymmetry of covariance products.
template <class Derived>
[[nodiscard]] typename Derived::PlainObject symmetrized(const Eigen::MatrixBase<Derived>& a) {
  return (0.5 * (a + a.transpose())).eval();
}

}  // namespace imm
