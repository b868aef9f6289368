// SPDX-License-Identifier: Apache-2.0
#pragma once
/// A constant-velocity Kalman mode driven by a known acceleration input, one axis:
/// x̂⁻ = F x̂₀ + G u, P⁻ = F P₀ Fᵀ + G q Gᵀ (seed 000 eq. 7-1, 7-2). The adaptive IMM sets u to
/// â(k−1) + ε_j before every cycle.

#include <string>
#include <utility>

#include "imm/filters/imm_mode.hpp"
#include "imm/filters/kalman_filter.hpp"
#include "imm/models/constant_velocity.hpp"

namespace imm {

class InputKalmanMode final : public ImmMode<2, 1> {
 public:
  InputKalmanMode(std::string name, double sample_period, double process_noise,
                  double measurement_variance)
      : name_(std::move(name)),
        motion_(constant_velocity<1>(sample_period, process_noise)),
        G_(cv_axis_input_gain(sample_period)),
        R_(SquareMatrix<1>::Constant(measurement_variance)) {
    detail::require_positive(measurement_variance, "measurement_variance");
    H_ << 1.0, 0.0;
  }

  void set_input(double acceleration) { input_ = acceleration; }
  [[nodiscard]] double input() const { return input_; }

  [[nodiscard]] std::string_view name() const override { return name_; }
  void embedded_estimate(Vector<2>& mean, SquareMatrix<2>& covariance) const override {
    mean = estimate_.mean;
    covariance = estimate_.covariance;
  }
  void reset(const GaussianState<2>& state) override { estimate_ = state; }

  ModeStep propose(const GaussianState<2>& mixed, const Vector<1>& z) override {
    pending_ = predict(mixed, motion_.transition, motion_.process_noise, G_, Vector<1>(input_));
    const auto report = update(pending_, z, H_, R_);
    return {report.status, report.log_likelihood};
  }

  ModeStep propose_prediction(const GaussianState<2>& mixed) override {
    pending_ = predict(mixed, motion_.transition, motion_.process_noise, G_, Vector<1>(input_));
    return {pending_.all_finite() ? StepStatus::kOk : StepStatus::kNonFiniteResult, 0.0};
  }

  void predicted_mean(const GaussianState<2>& mixed, Vector<2>& mean) const override {
    mean = motion_.transition * mixed.mean + G_ * input_;
  }

  void commit() override { estimate_ = pending_; }

 private:
  std::string name_;
  LinearMotionModel<2> motion_;
  Matrix<2, 1> G_;
  Matrix<1, 2> H_;
  SquareMatrix<1> R_;
  double input_ = 0.0;
  GaussianState<2> estimate_;
  GaussianState<2> pending_;
};

}  // namespace imm
