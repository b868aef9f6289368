// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// ImmEstimator's cycle in two halves — predict(), the candidate plots' scores, then update() or
/// miss() — defined apart from the class (imm_estimator.hpp, which includes this file).

#include <Eigen/Cholesky>
#include <limits>
#include <stdexcept>

#include "imm/estimation/imm_estimator.hpp"

namespace imm {

template <int NX, int NZ>
StepStatus ImmEstimator<NX, NZ>::predict() {
  require_initialized();
  if (!predicts_before_the_plot()) {
    throw std::logic_error("ImmEstimator::predict: a mode's prediction depends on the plot");
  }
  updated_ = false;
  predicted_ = false;
  predict_mode_probabilities();
  status_ = StepStatus::kOk;
  for (int j = 0; j < mode_count(); ++j) {
    mix(j, mixed_states_[index(j)]);
    if (!record(j, mode_at(j).propose_prediction(mixed_states_[index(j)]))) return status_;
  }
  predicted_ = true;
  return StepStatus::kOk;
}

template <int NX, int NZ>
double ImmEstimator<NX, NZ>::candidate_log_likelihood(const Vector<NZ>& z) const {
  if (!predicted_) return std::numeric_limits<double>::quiet_NaN();
  ModeVector terms(mode_count());
  for (int j = 0; j < mode_count(); ++j) {
    Vector<NZ> nu;
    SquareMatrix<NZ> S;
    if (!modes_[index(j)]->candidate_innovation(z, nu, S)) {
      return std::numeric_limits<double>::quiet_NaN();
    }
    terms(j) = log_predicted_(j) + log_normal_density(nu, S);
    if (std::isnan(terms(j))) return terms(j);
  }
  return log_sum_exp(terms);
}

template <int NX, int NZ>
double ImmEstimator<NX, NZ>::candidate_distance(const Vector<NZ>& z) const {
  Vector<NZ> nu;
  SquareMatrix<NZ> S;
  if (!candidate_moments(z, nu, S)) return std::numeric_limits<double>::quiet_NaN();
  const Eigen::LLT<SquareMatrix<NZ>> llt(S);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::quiet_NaN();
  return nu.dot(llt.solve(nu));
}

template <int NX, int NZ>
bool ImmEstimator<NX, NZ>::predicted_plot(Vector<NZ>& z_hat, SquareMatrix<NZ>& S) const {
  if (!predicted_) return false;
  int top = 0;
  for (int j = 1; j < mode_count(); ++j) {
    if (log_predicted_(j) > log_predicted_(top)) top = j;
  }
  Vector<NZ> reference;
  SquareMatrix<NZ> unused;
  if (!modes_[index(top)]->predicted_plot(reference, unused)) return false;
  Vector<NZ> nu;
  if (!candidate_moments(reference, nu, S)) return false;
  z_hat = reference - nu;
  return true;
}

template <int NX, int NZ>
StepStatus ImmEstimator<NX, NZ>::update(const Vector<NZ>& z) {
  require_predicted();
  updated_ = false;
  if (!limits::usable_measurement(z)) return StepStatus::kInvalidMeasurement;
  status_ = StepStatus::kOk;
  for (int j = 0; j < mode_count(); ++j) {
    if (!record(j, mode_at(j).propose_update(z))) break;
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
  for (int j = 0; j < mode_count(); ++j) {
    // Again from the held mixed estimate: an update tried before may have left its result
    // pending.
    if (!record(j, mode_at(j).propose_prediction(mixed_states_[index(j)]))) return status_;
  }
  const StepStatus status = finish_cycle();
  if (status == StepStatus::kOk) predicted_ = false;
  return status;
}

template <int NX, int NZ>
bool ImmEstimator<NX, NZ>::candidate_moments(const Vector<NZ>& z, Vector<NZ>& nu,
                                             SquareMatrix<NZ>& S) const {
  const int n = mode_count();
  std::array<Vector<NZ>, kMaxModes> nus;
  std::array<SquareMatrix<NZ>, kMaxModes> covariances;
  for (int j = 0; j < n; ++j) {
    if (!modes_[index(j)]->candidate_innovation(z, nus[index(j)], covariances[index(j)])) {
      return false;
    }
  }
  const double shift = log_predicted_.maxCoeff();
  double total = 0.0;
  for (int j = 0; j < n; ++j) total += std::exp(log_predicted_(j) - shift);
  nu.setZero();
  for (int j = 0; j < n; ++j) nu += std::exp(log_predicted_(j) - shift) / total * nus[index(j)];
  S.setZero();
  for (int j = 0; j < n; ++j) {
    const Vector<NZ> d = nus[index(j)] - nu;
    S += std::exp(log_predicted_(j) - shift) / total * (covariances[index(j)] + d * d.transpose());
  }
  return true;
}

}  // namespace imm
