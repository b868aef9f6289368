// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// ImmEstimator's cycle in two halves — predict(), the candidate plots' scores, then update() or
/// miss() — defined apart from the class (imm_estimator.hpp, which includes this file).

#include <Eigen/Cholesky>
#include <array>
#include <limits>
#include <stdexcept>

#include "imm/estimation/imm_algebra.hpp"
#include "imm/estimation/imm_estimator.hpp"

namespace imm {

template <int NX, int NZ>
StepStatus ImmEstimator<NX, NZ>::predict() {
  require_initialized();
  updated_ = false;
  predicted_ = false;
  trial_ = !predicts_before_the_plot();
  plot_free_pending_ = false;
  predict_mode_probabilities();
  status_ = StepStatus::kOk;
  for (int j = 0; j < mode_count(); ++j) {
    mix(j, mixed_states_[index(j)]);
    if (!trial_ && !record(j, mode_at(j).propose_prediction(mixed_states_[index(j)]))) {
      return status_;
    }
  }
  predicted_ = true;
  // A trial's modes hold no prediction: miss() makes it.
  prediction_intact_ = !trial_;
  return StepStatus::kOk;
}

template <int NX, int NZ>
double ImmEstimator<NX, NZ>::candidate_log_likelihood(const Vector<NZ>& z) const {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (!predicted_) return kNaN;
  if (!trial_) return mixture_log_density(innovations_of_candidate(z));
  // record()'s ℓ_j + log c_j and log_predictive_likelihood()'s sum, in their order.
  ModeVector terms(mode_count());
  if (!trial_update(z, terms)) return kNaN;
  for (int j = 0; j < mode_count(); ++j) terms(j) = terms(j) + log_predicted_(j);
  return log_sum_exp(terms);
}

template <int NX, int NZ>
double ImmEstimator<NX, NZ>::candidate_distance(const Vector<NZ>& z) const {
  Vector<NZ> nu;
  SquareMatrix<NZ> S;
  // Under a trial, the gate is the prediction stated before the plot (predicted_plot()'s).
  if (!predicted_ || !predict_without_the_plot() || !collapse(innovations_of_candidate(z), nu, S)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const Eigen::LLT<SquareMatrix<NZ>> llt(S);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::quiet_NaN();
  return nu.dot(llt.solve(nu));
}

template <int NX, int NZ>
bool ImmEstimator<NX, NZ>::predicted_plot(Vector<NZ>& z_hat, SquareMatrix<NZ>& S) const {
  if (!predicted_ || !predict_without_the_plot()) return false;
  int top = 0;
  for (int j = 1; j < mode_count(); ++j) {
    if (log_predicted_(j) > log_predicted_(top)) top = j;
  }
  Vector<NZ> reference;
  SquareMatrix<NZ> unused;
  if (!modes_[index(top)]->predicted_plot(reference, unused)) return false;
  Vector<NZ> nu;
  if (!collapse(innovations_of_candidate(reference), nu, S)) return false;
  z_hat = reference - nu;
  return true;
}

template <int NX, int NZ>
StepStatus ImmEstimator<NX, NZ>::update(const Vector<NZ>& z) {
  require_predicted();
  updated_ = false;
  if (!limits::usable_measurement(z)) return StepStatus::kInvalidMeasurement;
  prediction_intact_ = false;
  plot_free_pending_ = false;
  status_ = StepStatus::kOk;
  for (int j = 0; j < mode_count(); ++j) {
    // step()'s propose() from the same mixing where the prediction depends on the plot.
    const ModeStep result =
        trial_ ? mode_at(j).propose(mixed_states_[index(j)], z) : mode_at(j).propose_update(z);
    if (!record(j, result)) break;
  }
  const StepStatus status = finish_update();
  if (status == StepStatus::kOk) predicted_ = false;
  return status;
}

template <int NX, int NZ>
StepStatus ImmEstimator<NX, NZ>::miss() {
  require_predicted();
  updated_ = false;
  status_ = StepStatus::kOk;
  // An update tried since predict() left its results pending in the modes and in the posterior:
  // predict again from the held mixed estimates.
  for (int j = 0; !prediction_intact_ && j < mode_count(); ++j) {
    if (!record(j, mode_at(j).propose_prediction(mixed_states_[index(j)]))) return status_;
  }
  prediction_intact_ = true;
  const StepStatus status = finish_cycle();
  if (status == StepStatus::kOk) predicted_ = false;
  return status;
}

template <int NX, int NZ>
template <class Of>
bool ImmEstimator<NX, NZ>::collapse(Of&& of, Vector<NZ>& nu, SquareMatrix<NZ>& S) const {
  const int n = mode_count();
  std::array<Vector<NZ>, kMaxModes> nus;
  std::array<SquareMatrix<NZ>, kMaxModes> covariances;
  for (int j = 0; j < n; ++j) {
    if (!of(j, nus[index(j)], covariances[index(j)])) return false;
  }
  // c_j, normalized over the modes (predict_mode_probabilities keeps them in log space).
  std::array<double, kMaxModes> c{};
  algebra::normalized<algebra::LibmFunctions, double>(
      n, [this](int j) { return log_predicted_(j); }, c);
  nu.setZero();
  for (int j = 0; j < n; ++j) {
    if (c[index(j)] != 0.0) nu += c[index(j)] * nus[index(j)];
  }
  S.setZero();
  for (int j = 0; j < n; ++j) {
    if (c[index(j)] == 0.0) continue;
    const Vector<NZ> d = nus[index(j)] - nu;
    S += c[index(j)] * (covariances[index(j)] + d * d.transpose());
  }
  return true;
}

template <int NX, int NZ>
template <class Of>
double ImmEstimator<NX, NZ>::mixture_log_density(Of&& of) const {
  const int n = mode_count();
  ModeVector terms(n);
  for (int j = 0; j < n; ++j) {
    Vector<NZ> nu;
    SquareMatrix<NZ> S;
    if (!of(j, nu, S)) return std::numeric_limits<double>::quiet_NaN();
    terms(j) = log_predicted_(j) + log_normal_density(nu, S);
    if (std::isnan(terms(j))) return terms(j);
  }
  return log_sum_exp(terms);
}

}  // namespace imm
