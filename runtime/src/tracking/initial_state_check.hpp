// SPDX-License-Identifier: Apache-2.0
#pragma once
// What a track may start from: one check for the one-track filters (require_initial_state) and
// every bank's initialize, so that a bank starts a track only from what its filter starts from.
// Fixed-size arguments allocate nothing. Not installed.

#include <Eigen/Core>
#include <string>

#include "imm/core/invalid_parameter.hpp"
#include "imm/estimation/gaussian_state.hpp"

namespace imm::detail {

/// Throws InvalidParameter("initial_state") for a mean that is not `dimension` finite numbers,
/// ("initial_covariance") for a covariance that is not `dimension` × `dimension`, finite and
/// symmetric (to 1e-12 relative) with a non-negative diagonal.
template <class Mean, class Covariance>
void check_initial_state(const Eigen::MatrixBase<Mean>& mean,
                         const Eigen::MatrixBase<Covariance>& covariance, int dimension) {
  if (mean.size() != dimension || !mean.allFinite()) {
    throw InvalidParameter(
        "initial_state", "must be " + std::to_string(dimension) + " finite numbers, one per state");
  }
  if (covariance.rows() != dimension || covariance.cols() != dimension || !covariance.allFinite() ||
      !covariance.isApprox(covariance.transpose(), 1e-12) ||
      (covariance.diagonal().array() < 0.0).any()) {
    const std::string n = std::to_string(dimension);
    throw InvalidParameter(
        "initial_covariance",
        "must be " + n + " × " + n + ", finite and symmetric with a non-negative diagonal");
  }
}

/// check_initial_state of a bank's start.
template <int N>
void check_initial_state(const GaussianState<N>& state) {
  check_initial_state(state.mean, state.covariance, N);
}

}  // namespace imm::detail
