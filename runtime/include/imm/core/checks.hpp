// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The parameter checks the runtime's models and filters share, each naming the parameter it
/// refuses: a positive or non-negative scalar, a measurement covariance, and the transition
/// matrix and prior of an IMM.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cmath>
#include <stdexcept>
#include <string>

#include "imm/runtime_export.hpp"

namespace imm {

/// Throws std::invalid_argument naming `field` unless `value` is positive and finite.
inline void require_positive(double value, const char* field) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string(field) + " must be positive and finite, got " +
                                std::to_string(value));
  }
}

/// Throws std::invalid_argument naming `field` unless `value` is non-negative and finite.
inline void require_non_negative(double value, const char* field) {
  if (!(value >= 0.0) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string(field) + " must be non-negative and finite, got " +
                                std::to_string(value));
  }
}

/// Throws std::invalid_argument naming `field` unless R is finite, symmetric and positive
/// definite.
template <int M>
void require_measurement_covariance(const Eigen::Matrix<double, M, M>& R, const char* field) {
  if (!R.allFinite()) throw std::invalid_argument(std::string(field) + " has non-finite entries");
  if (!R.isApprox(R.transpose(), 1e-12)) {
    throw std::invalid_argument(std::string(field) + " is not symmetric");
  }
  if (Eigen::LLT<Eigen::Matrix<double, M, M>>(R).info() != Eigen::Success) {
    throw std::invalid_argument(std::string(field) + " is not positive definite");
  }
}

/// Validates a row-stochastic transition matrix and a probability vector for `modes` modes;
/// throws InvalidParameter naming "transition" or "initial_probabilities".
IMM_RUNTIME_EXPORT void validate_mode_probabilities(const Eigen::MatrixXd& transition,
                                                    const Eigen::VectorXd& initial_probabilities,
                                                    int modes);

}  // namespace imm
