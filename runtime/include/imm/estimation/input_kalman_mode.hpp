// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// A constant-velocity Kalman mode driven by a known acceleration input, one axis:
/// x̂⁻ = F x̂₀ + G u, P⁻ = F P₀ Fᵀ + G q Gᵀ (seed 000 eq. 7-1, 7-2). The adaptive IMM sets u to
/// â(k−1) + ε_j before every cycle.

#include <string>
#include <utility>

#include "imm/core/checks.hpp"
#include "imm/estimation/imm_mode.hpp"
#include "imm/estimation/kalman_filter.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// A CV Kalman mode of one axis driven by a known acceleration input u (x⁺ = F x + G u): the AIMM's
/// sub-model.
class IMM_RUNTIME_EXPORT InputKalmanMode final : public ImmMode<2, 1> {
 public:
  /// Throws InvalidParameter naming the field: a non-positive sample period or measurement
  /// variance, a negative process noise.
  InputKalmanMode(std::string name, double sample_period, double process_noise,
                  double measurement_variance)
      : name_(std::move(name)),
        motion_(constant_velocity<1>(sample_period, process_noise)),
        G_(cv_axis_input_gain(sample_period)),
        R_(SquareMatrix<1>::Constant(measurement_variance)) {
    require_positive(measurement_variance, "measurement_variance");
    H_ << 1.0, 0.0;
  }

  /// Sets the input u used from the next propose on.
  void set_input(double acceleration) { input_ = acceleration; }
  /// The current input u.
  [[nodiscard]] double input() const { return input_; }

  [[nodiscard]] std::string_view name() const override { return name_; }
  /// The current estimate (the mixing space is the mode's).
  void embedded_estimate(Vector<2>& mean, SquareMatrix<2>& covariance) const override {
    mean = estimate_.mean;
    covariance = estimate_.covariance;
  }
  /// Sets the estimate.
  void reset(const GaussianState<2>& state) override { estimate_ = state; }

  /// Predicts with the input and updates with z; pending until commit().
  ModeStep propose(const GaussianState<2>& mixed, const Vector<1>& z) override {
    pending_ = predict(mixed, motion_.transition, motion_.process_noise, G_, Vector<1>(input_));
    const auto report = update(pending_, z, H_, R_);
    keep_innovation(report.innovation, report.innovation_covariance);
    return {report.status, report.log_likelihood};
  }

  /// Predicts with the input; pending until commit().
  ModeStep propose_prediction(const GaussianState<2>& mixed) override {
    pending_ = predict(mixed, motion_.transition, motion_.process_noise, G_, Vector<1>(input_));
    return {pending_.all_finite() ? StepStatus::kOk : StepStatus::kNonFiniteResult, 0.0};
  }

  /// F times the mixed mean plus G u.
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
