// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Mode transition probabilities from a continuous-time generator. A Markov chain of modes that
/// switches in continuous time has a generator Q (q_ij ≥ 0 the rate from mode i to mode j, rows
/// summing to zero, −q_ii = 1 / the mean sojourn time in mode i); sampled every T seconds it is
/// the discrete chain with Π(T) = exp(Q T) (Bar-Shalom, Li & Kirubarajan §11.6.3). A model that
/// stores Q instead of Π stays valid when the sample period changes.

#include <Eigen/Core>

#include "imm/runtime_export.hpp"

namespace imm {

/// Throws InvalidParameter("generator", …) unless Q is square, finite, with non-negative
/// off-diagonal rates and rows that sum to zero (to 1e-9 of the row's largest rate).
IMM_RUNTIME_EXPORT void validate_generator(const Eigen::MatrixXd& generator);

/// Π(T) = exp(Q T) for a valid generator and a sample period T > 0: a row-stochastic matrix.
[[nodiscard]] IMM_RUNTIME_EXPORT Eigen::MatrixXd transition_matrix(const Eigen::MatrixXd& generator,
                                                                   double sample_period);

/// The generator of the two-mode chain whose mean sojourn times are `first` and `second` seconds
/// (each mode left only for the other).
[[nodiscard]] IMM_RUNTIME_EXPORT Eigen::MatrixXd two_mode_generator(double first, double second);

}  // namespace imm
