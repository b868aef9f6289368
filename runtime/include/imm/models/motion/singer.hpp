// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Singer model: per axis [p, v, a] with the acceleration a first-order Markov process,
/// ȧ = −a/τ + w, w white of PSD q = 2σ_a²/τ, so that the stationary variance of a is σ_a².
///
/// Exact discretization (Singer 1970; seed 004 eq. 14, 17–18) with α = 1/τ:
///   F = [[1, T, (αT − 1 + e^{−αT})/α²], [0, 1, (1 − e^{−αT})/α], [0, 0, e^{−αT}]],
///   Q = q [Q_ij] with Q₁₁ = (1 − e^{−2αT} + 2αT + ⅔α³T³ − 2α²T² − 4αT e^{−αT})/(2α⁵), …,
///   Q₃₃ = (1 − e^{−2αT})/(2α).
/// Deviations from the seed's print: the exponentials decay (e^{−T/τ}; the seed drops the
/// minus sign), and Q₃₃ has 1/(2α) = τ/2 where the seed prints τ/4 — only τ/2 gives the
/// stationary variance q τ/2 = σ_a². The brackets cancel catastrophically for small αT, so they
/// are evaluated by their Taylor series there (see singer.cpp).
///
/// Limits: τ → ∞ with q fixed gives the CA model with continuous white jerk; τ → 0 with
/// 2σ_a²τ fixed gives, in the [p, v] block, the CV model with continuous white acceleration.

#include "imm/core/checks.hpp"
#include "imm/models/motion/motion_model.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// Per-axis F of the Singer model.
[[nodiscard]] IMM_RUNTIME_EXPORT SquareMatrix<3> singer_axis_transition(double T, double tau);

/// Per-axis Q of the Singer model for acceleration standard deviation sigma_a.
[[nodiscard]] IMM_RUNTIME_EXPORT SquareMatrix<3> singer_axis_noise(double T, double tau,
                                                                   double sigma_a);

/// D-axis Singer model, state [p₁, v₁, a₁, p₂, v₂, a₂, …].
template <int D>
[[nodiscard]] LinearMotionModel<3 * D> singer(double sample_period, double tau, double sigma_a) {
  require_positive(sample_period, "sample_period");
  require_positive(tau, "tau");
  require_non_negative(sigma_a, "sigma_a");
  return per_axis_model<D>(singer_axis_transition(sample_period, tau),
                           singer_axis_noise(sample_period, tau, sigma_a));
}

}  // namespace imm
