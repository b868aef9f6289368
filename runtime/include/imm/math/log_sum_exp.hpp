// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Log-space arithmetic for model probabilities (seed 000 eq. 8): likelihoods of far-off modes
/// underflow in linear space long before they matter, so the IMM keeps log μ and normalizes with
/// log-sum-exp.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cmath>
#include <limits>

namespace imm {

/// log(2π): the normal density's constant, log N(ν; 0, S) = −½ (νᵀ S⁻¹ ν + log det S + n log 2π).
inline constexpr double kLogTwoPi = 1.8378770664093454836;
/// log(2π e): twice a unit normal's entropy, ½ log(2π e σ²) being a N(0, σ²) plot noise's.
inline constexpr double kLogTwoPiE = 2.8378770664093454836;

/// log N(ν; 0, S) by a Cholesky factor of S; NaN where S is not positive definite.
template <int N>
[[nodiscard]] double log_normal_density(const Eigen::Matrix<double, N, 1>& nu,
                                        const Eigen::Matrix<double, N, N>& S) {
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(S);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::quiet_NaN();
  const Eigen::Matrix<double, N, N> L = llt.matrixL();
  const double log_det = 2.0 * L.diagonal().array().log().sum();
  return -0.5 * (nu.dot(llt.solve(nu)) + log_det + N * kLogTwoPi);
}

/// log Σ exp(v_i), stable for any finite or −∞ entries. Returns −∞ when every entry is −∞ (or the
/// vector is empty) and NaN when an entry is NaN or +∞.
template <class Derived>
[[nodiscard]] double log_sum_exp(const Eigen::DenseBase<Derived>& values) {
  constexpr double kMinusInf = -std::numeric_limits<double>::infinity();
  double max_value = kMinusInf;
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    const double v = values(i);
    if (std::isnan(v) || v == std::numeric_limits<double>::infinity()) {
      return std::numeric_limits<double>::quiet_NaN();
    }
    if (v > max_value) max_value = v;
  }
  if (max_value == kMinusInf) return kMinusInf;
  double sum = 0.0;
  for (Eigen::Index i = 0; i < values.size(); ++i) sum += std::exp(values(i) - max_value);
  // sum ≥ 1: the largest entry contributes exp(0).
  return max_value + std::log(sum);  // cppcheck-suppress invalidFunctionArg
}

/// log(x) with log(0) = −∞ (no floating-point exception flags beyond what std::log raises).
[[nodiscard]] inline double safe_log(double x) {
  return x > 0.0 ? std::log(x) : -std::numeric_limits<double>::infinity();
}

}  // namespace imm
