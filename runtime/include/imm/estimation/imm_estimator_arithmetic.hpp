// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// ImmEstimator's arithmetic over the mode probabilities and the modes' Gaussians — the predicted
/// mode probabilities (eq. 8's inner sum), the mixing (eq. 4–6), the posterior in log space
/// (eq. 8–9) and the combination (eq. 10–11) — defined apart from the class (imm_estimator.hpp,
/// which includes this file; the comments on each are at its declaration there). The mode
/// probabilities and the mixing weights are the banks' arithmetic (imm_algebra.hpp) over a double
/// with libm's exp and log; the collapse is Eigen's, in the algebra's order of operations (its
/// scalar form over a double costs W1's step 15 %: docs/performance.md).

#include <cmath>
#include <limits>

#include "imm/estimation/imm_algebra.hpp"
#include "imm/estimation/imm_estimator.hpp"

namespace imm {

template <int NX, int NZ>
inline void ImmEstimator<NX, NZ>::predict_mode_probabilities() {
  const int n = mode_count();
  const double shift =
      algebra::scaled_probabilities<algebra::LibmFunctions>(n, log_probabilities_, scaled_);
  for (int j = 0; j < n; ++j) {
    const double c = algebra::predicted_scaled(n, j, transition_, scaled_);
    predicted_scaled_(j) = c;
    log_predicted_(j) =
        c > 0.0 ? std::log(c) + shift
                : algebra::exact_log_prediction(n, j, log_transition_,
                                                [this](int i) { return log_probabilities_(i); });
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
    algebra::mixing_weights<algebra::Division::kDivide>(
        n, j, transition_, scaled_, predicted_scaled_(j),
        [this](int i) -> double& { return scratch_(i); });
  } else {
    for (int i = 0; i < n; ++i) {
      scratch_(i) = algebra::exact_mixing_weight(i, j, log_transition_(i, j), log_probabilities_(i),
                                                 log_predicted_(j));
    }
  }
  moment_match(scratch_, mixed);
}

template <int NX, int NZ>
inline StepStatus ImmEstimator<NX, NZ>::finish_cycle() {
  if (status_ != StepStatus::kOk) return status_;
  const int n = mode_count();
  double sum = 0.0;
  double log_sum = 0.0;
  const double top = algebra::posterior<algebra::LibmFunctions>(n, log_posterior_, scratch_,
                                                                scaled_, sum, log_sum);
  if (!std::isfinite(top)) return StepStatus::kProbabilityUnderflow;
  for (auto& mode : modes_) mode->commit();
  // log μ_j = (ℓ_j − top) − log Σ (algebra::posterior).
  for (int j = 0; j < n; ++j) log_probabilities_(j) = scratch_(j) - log_sum;
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
