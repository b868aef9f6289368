// SPDX-License-Identifier: Apache-2.0
#include "estimation/cv_position_mode.hpp"

#include <cmath>
#include <utility>

#include "imm/core/physical_limits.hpp"
#include "imm/math/log_sum_exp.hpp"

namespace imm {
namespace {

using cv_position::kEntries;
using cv_position::kN;
using cv_position::sym;

}  // namespace

CvPositionMode::CvPositionMode(std::string name, double sample_period,
                               const SquareMatrix<4>& process_noise,
                               const SquareMatrix<2>& measurement_covariance,
                               MotionMaker<LinearMotionModel<4>> maker)
    : name_(std::move(name)),
      period_(sample_period),
      r00_(measurement_covariance(0, 0)),
      r01_(measurement_covariance(0, 1)),
      r11_(measurement_covariance(1, 1)),
      maker_(maker) {
  set_noise(process_noise);
}

void CvPositionMode::set_noise(const SquareMatrix<4>& process_noise) {
  for (int a = 0; a < kN; ++a)
    for (int c = a; c < kN; ++c) noise_[static_cast<std::size_t>(sym(a, c))] = process_noise(a, c);
}

bool CvPositionMode::set_interval(double interval) {
  if (!maker_ || !(interval > 0.0) || !std::isfinite(interval)) return false;
  if (interval != interval_) {
    const LinearMotionModel<4> motion = maker_(interval);
    if (!motion.process_noise.allFinite()) return false;
    period_ = motion.transition(0, 1);
    set_noise(motion.process_noise);
    interval_ = interval;
  }
  return true;
}

void CvPositionMode::load(const GaussianState<4>& state, Entries& entries) {
  for (int a = 0; a < kN; ++a) {
    entries[static_cast<std::size_t>(a)] = state.mean(a);
    for (int c = a; c < kN; ++c) {
      const int entry = kN + sym(a, c);
      entries[static_cast<std::size_t>(entry)] = state.covariance(a, c);
    }
  }
}

void CvPositionMode::embedded_estimate(Vector<4>& mean, SquareMatrix<4>& covariance) const {
  for (int a = 0; a < kN; ++a) {
    mean(a) = estimate_[static_cast<std::size_t>(a)];
    for (int c = 0; c < kN; ++c) {
      const int entry = kN + sym(a, c);
      covariance(a, c) = estimate_[static_cast<std::size_t>(entry)];
    }
  }
}

void CvPositionMode::reset(const GaussianState<4>& state) { load(state, estimate_); }

void CvPositionMode::predict_mixed(const GaussianState<4>& mixed) {
  load(mixed, predicted_);
  cv_position::predict([&](int e) -> double& { return predicted_[static_cast<std::size_t>(e)]; },
                       period_, noise_.data());
}

[[gnu::flatten]] ModeStep CvPositionMode::propose(const GaussianState<4>& mixed,
                                                  const Vector<2>& z) {
  predict_mixed(mixed);
  return update_predicted(z);
}

ModeStep CvPositionMode::propose_update(const Vector<2>& z) { return update_predicted(z); }

[[gnu::flatten]] ModeStep CvPositionMode::update_predicted(const Vector<2>& z) {
  Entries updated;
  const auto o =
      cv_position::update([&](int e) { return predicted_[static_cast<std::size_t>(e)]; },
                          [&](int e) -> double& { return updated[static_cast<std::size_t>(e)]; },
                          z(0), z(1), r00_, r01_, r11_);
  // Element by element: a 2-vector built on the stack and copied stalls on store forwarding.
  Vector<2>& innovation = kept_innovation();
  innovation(0) = o.nu0;
  innovation(1) = o.nu1;
  SquareMatrix<2>& S = kept_innovation_covariance();
  S(0, 0) = o.s00;
  S(0, 1) = o.s01;
  S(1, 0) = o.s01;
  S(1, 1) = o.s11;
  // S positive definite and finite (Sylvester, with kalman_filter.hpp's relative guard), then
  // every output finite: the checks and statuses of update_with_innovation.
  if (!(o.s00 > 0.0) || !(o.det > o.threshold) || !std::isfinite(o.det)) {
    return {StepStatus::kSingularInnovation, 0.0};
  }
  if (o.finite != 0.0) return {StepStatus::kNonFiniteResult, 0.0};
  pending_ = updated;
  return {StepStatus::kOk, -0.5 * (o.mahalanobis + std::log(o.det) + 2 * kLogTwoPi)};
}

ModeStep CvPositionMode::propose_prediction(const GaussianState<4>& mixed) {
  predict_mixed(mixed);
  pending_ = predicted_;
  bool finite = true;
  for (const double value : pending_) finite = finite && std::isfinite(value);
  return {finite ? StepStatus::kOk : StepStatus::kNonFiniteResult, 0.0};
}

bool CvPositionMode::predicted_plot(Vector<2>& z_hat, SquareMatrix<2>& S) const {
  const auto at = [&](int e) { return predicted_[static_cast<std::size_t>(e)]; };
  z_hat << at(0), at(2);
  S << at(kN + sym(0, 0)) + r00_, at(kN + sym(0, 2)) + r01_, at(kN + sym(0, 2)) + r01_,
      at(kN + sym(2, 2)) + r11_;
  return true;
}

bool CvPositionMode::candidate_innovation(const Vector<2>& z, Vector<2>& nu,
                                          SquareMatrix<2>& S) const {
  if (!limits::usable_measurement(z)) return false;
  Vector<2> z_hat;
  (void)predicted_plot(z_hat, S);
  nu = z - z_hat;
  return true;
}

void CvPositionMode::predicted_mean(const GaussianState<4>& mixed, Vector<4>& mean) const {
  mean(0) = mixed.mean(0) + period_ * mixed.mean(1);
  mean(1) = mixed.mean(1);
  mean(2) = mixed.mean(2) + period_ * mixed.mean(3);
  mean(3) = mixed.mean(3);
}

}  // namespace imm
