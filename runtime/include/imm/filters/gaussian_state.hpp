// SPDX-License-Identifier: Apache-2.0
#pragma once
/// A Gaussian estimate: mean and covariance, fixed size.

#include "imm/math/linear_algebra.hpp"

namespace imm {

template <int N>
struct GaussianState {
  static_assert(N > 0, "state dimension must be positive");
  static constexpr int kDim = N;

  Vector<N> mean = Vector<N>::Zero();
  SquareMatrix<N> covariance = SquareMatrix<N>::Identity();

  [[nodiscard]] bool all_finite() const { return mean.allFinite() && covariance.allFinite(); }
};

}  // namespace imm
