// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The χ² distribution's quantiles, for consistency bounds (the evaluations' NEES and NIS, a
/// tracker's envelope monitor): the regularized incomplete gamma function by its series and
/// continued fraction, inverted by bisection with Newton steps.

#include "imm/runtime_export.hpp"

namespace imm {

/// The regularized lower incomplete gamma function P(a, x) = γ(a, x) / Γ(a), a > 0, x ≥ 0: the
/// χ² CDF with k degrees of freedom is P(k/2, x/2). Throws std::invalid_argument outside its
/// domain.
[[nodiscard]] IMM_RUNTIME_EXPORT double regularized_gamma_p(double a, double x);

/// The x with P(χ²_dof ≤ x) = p, for 0 < p < 1 and dof > 0 (relative accuracy ~1e-12). Throws
/// std::invalid_argument outside that domain.
[[nodiscard]] IMM_RUNTIME_EXPORT double chi_square_quantile(double p, double dof);

}  // namespace imm
