// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// A Gaussian estimate: mean and covariance, fixed size.

#include "imm/math/linear_algebra.hpp"

namespace imm {

/// A Gaussian estimate of a fixed-size state: mean and covariance.
template <int N>
struct GaussianState {
  static_assert(N > 0, "state dimension must be positive");
  /// The state dimension.
  static constexpr int kDim = N;

  /// The mean.
  Vector<N> mean = Vector<N>::Zero();
  /// The covariance (symmetric positive semi-definite).
  SquareMatrix<N> covariance = SquareMatrix<N>::Identity();

  /// Whether the mean and the covariance are free of NaN and Inf.
  [[nodiscard]] bool all_finite() const { return mean.allFinite() && covariance.allFinite(); }
  /// all_finite(), and no negative variance: what an update or a prediction may leave. A filter
  /// driven far beyond its model (variances of 10²⁰ collapsing to 10⁴ in one update) can lose the
  /// covariance's definiteness to rounding even in Joseph form; such a step is refused.
  [[nodiscard]] bool usable() const {
    return all_finite() && (covariance.diagonal().array() >= 0.0).all();
  }
};

}  // namespace imm
