// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Mode transition probabilities from a continuous-time generator. A Markov chain of modes that
/// switches in continuous time has a generator Q (q_ij ≥ 0 the rate from mode i to mode j, rows
/// summing to zero, −q_ii = 1 / the mean sojourn time in mode i); sampled every T seconds it is
/// the discrete chain with Π(T) = exp(Q T) (Bar-Shalom, Li & Kirubarajan §11.6.3). A model that
/// stores Q instead of Π stays valid when the sample period changes.

#include <Eigen/Core>

#include "imm/math/linear_algebra.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// Throws InvalidParameter("generator", …) unless Q is square, finite, with non-negative
/// off-diagonal rates and rows that sum to zero (to 1e-9 of the row's largest rate).
IMM_RUNTIME_EXPORT void validate_generator(const Eigen::MatrixXd& generator);

/// Π(T) = exp(Q T) for a valid generator and a sample period T > 0: a row-stochastic matrix.
[[nodiscard]] IMM_RUNTIME_EXPORT Eigen::MatrixXd transition_matrix(const Eigen::MatrixXd& generator,
                                                                   double sample_period);

/// Π over an interval of `periods` sample periods (Δt / T, positive and finite) from the
/// per-period Π, keeping each mode's mean sojourn time and where a switch goes: mode i is left at
/// the rate −ln p_ii / T for the modes Π sends it to, so
///   p_ii(Δt) = p_ii^(Δt/T),   p_ij(Δt) = p_ij (1 − p_ii(Δt)) / (1 − p_ii)   (j ≠ i),
/// a row-stochastic matrix; a mode that is never left (p_ii = 1) stays so. Π itself, to the bit, at
/// Δt = T. What a plain IMM fed time stamps uses (a model that stores a generator uses
/// transition_matrix, exact at any interval). `out` is resized to Π's size, within ModeMatrix's
/// inline storage: no allocation.
IMM_RUNTIME_EXPORT void transition_over(const ModeMatrix& per_period, double periods,
                                        ModeMatrix& out);

/// The generator of the two-mode chain whose mean sojourn times are `first` and `second` seconds
/// (each mode left only for the other).
[[nodiscard]] IMM_RUNTIME_EXPORT Eigen::MatrixXd two_mode_generator(double first, double second);

}  // namespace imm
