// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// ImmEstimator's arithmetic over the mode probabilities and the modes' Gaussians — the predicted
/// mode probabilities (eq. 8's inner sum), the mixing (eq. 4–6), the posterior in log space
/// (eq. 8–9) and the combination (eq. 10–11) — defined apart from the class (imm_estimator.hpp,
/// which includes this file; the comments on each are at its declaration there).

#include <cmath>
#include <limits>

#include "imm/estimation/imm_estimator.hpp"
#include "imm/math/log_sum_exp.hpp"

namespace imm {
namespace detail {
/// e^d of a difference from a maximum: 1 for the maximum's own d = ±0 (exp's value there, which
/// IEEE 754 fixes), libm's exp otherwise. One call of libm fewer per normalization.
[[nodiscard, gnu::always_inline]] inline double exp_of_difference(double d) {
  return d == 0.0 ? 1.0 : std::exp(d);
}
}  // namespace detail

template <int NX, int NZ>
inline void ImmEstimator<NX, NZ>::predict_mode_probabilities() {
  const int n = mode_count();
  const double shift = log_probabilities_.maxCoeff();
  for (int i = 0; i < n; ++i) scaled_(i) = detail::exp_of_difference(log_probabilities_(i) - shift);
  for (int j = 0; j < n; ++j) {
    double c = 0.0;
    for (int i = 0; i < n; ++i) c += transition_(i, j) * scaled_(i);
    predicted_scaled_(j) = c;
    if (c > 0.0) {
      log_predicted_(j) = std::log(c) + shift;
    } else {
      for (int i = 0; i < n; ++i) scratch_(i) = log_transition_(i, j) + log_probabilities_(i);
      log_predicted_(j) = log_sum_exp(scratch_);
    }
  }
}

template <int NX, int NZ>
inline void ImmEstimator<NX, NZ>::mix(int j, GaussianState<NX>& mixed) {
  const int n = mode_count();
  // means_/covariances_ hold every mode's current estimate (see combine()).
  if (log_predicted_(j) == -std::numeric_limits<double>::infinity()) {
    // Mode j is unreachable under Π and μ: its weights are undefined; it keeps its own
    // estimate as the initial condition and its probability stays zero.
    mixed.mean = means_[index(j)];
    mixed.covariance = covariances_[index(j)];
    return;
  }
  if (predicted_scaled_(j) > 0.0) {
    for (int i = 0; i < n; ++i) {
      scratch_(i) = transition_(i, j) * scaled_(i) / predicted_scaled_(j);
    }
  } else {
    for (int i = 0; i < n; ++i) {
      scratch_(i) = std::exp(log_transition_(i, j) + log_probabilities_(i) - log_predicted_(j));
    }
  }
  moment_match(scratch_, mixed);
}

template <int NX, int NZ>
inline StepStatus ImmEstimator<NX, NZ>::finish_cycle() {
  if (status_ != StepStatus::kOk) return status_;
  const int n = mode_count();
  const double shift = log_posterior_.maxCoeff();
  if (!std::isfinite(shift)) return StepStatus::kProbabilityUnderflow;
  double sum = 0.0;
  for (int j = 0; j < n; ++j) {
    scaled_(j) = detail::exp_of_difference(log_posterior_(j) - shift);
    sum += scaled_(j);
  }
  // sum ≥ 1: the largest entry contributes exp(0). log μ_j = (ℓ_j − shift) − log sum, in that
  // order: with log-likelihoods far from zero (a plot many σ away gives ℓ ≈ −1e30) the sum
  // shift + log sum rounds to shift, and ℓ_j − (shift + log sum) would give two modes log μ = 0.
  const double log_sum = std::log(sum);  // cppcheck-suppress invalidFunctionArg
  for (auto& mode : modes_) mode->commit();
  log_probabilities_ = (log_posterior_.array() - shift) - log_sum;
  scaled_ /= sum;
  combine(scaled_);
  return StepStatus::kOk;
}

template <int NX, int NZ>
inline void ImmEstimator<NX, NZ>::combine(const ModeVector& mu) {
  const int n = mode_count();
  for (int j = 0; j < n; ++j)
    mode_at(j).embedded_estimate(means_[index(j)], covariances_[index(j)]);
  moment_match(mu, combined_);
}

template <int NX, int NZ>
inline void ImmEstimator<NX, NZ>::combine() {
  const int n = mode_count();
  for (int j = 0; j < n; ++j) scaled_(j) = std::exp(log_probabilities_(j));
  combine(scaled_);
}

template <int NX, int NZ>
inline void ImmEstimator<NX, NZ>::moment_match(const ModeVector& weights,
                                               GaussianState<NX>& out) const {
  const int n = mode_count();
  // Summed in locals, which stay in registers, and stored once.
  Vector<NX> mean = Vector<NX>::Zero();
  for (int i = 0; i < n; ++i) mean += weights(i) * means_[index(i)];
  SquareMatrix<NX> covariance = SquareMatrix<NX>::Zero();
  for (int i = 0; i < n; ++i) {
    if (weights(i) == 0.0) continue;
    const Vector<NX> d = means_[index(i)] - mean;
    covariance += weights(i) * (covariances_[index(i)] + d * d.transpose());
  }
  out.mean = mean;
  out.covariance = covariance;
}

}  // namespace imm
