// SPDX-License-Identifier: Apache-2.0
#include "imm/tracking/track_filter.hpp"

#include <string>

#include "imm/core/invalid_parameter.hpp"

namespace imm {

void require_initial_state(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance,
                           int dimension) {
  const std::string n = std::to_string(dimension);
  if (mean.size() != dimension || !mean.allFinite()) {
    throw InvalidParameter("initial_state", "must be " + n + " finite numbers, one per state");
  }
  if (covariance.rows() != dimension || covariance.cols() != dimension || !covariance.allFinite() ||
      !covariance.isApprox(covariance.transpose(), 1e-12) ||
      (covariance.diagonal().array() < 0.0).any()) {
    throw InvalidParameter(
        "initial_covariance",
        "must be " + n + " × " + n + ", finite and symmetric with a non-negative diagonal");
  }
}

}  // namespace imm
