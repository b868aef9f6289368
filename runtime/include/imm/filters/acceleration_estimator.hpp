// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The acceleration estimate of the adaptive IMM (seed 000 §2.2, after Munir & Atherton): per axis,
/// the target's acceleration is a random bias b on the constant-velocity model,
///   x(k+1) = F x(k) + G (b(k) + w(k)),  b(k+1) = b(k) + w_b(k),  z = H x + v,
/// with w the bias-free process noise (σ 0.001 km/s² in the seed) and w_b the bias noise
/// (σ 0.01 km/s²). The seed estimates b with the two-stage Kalman estimator of Alouani et al.
/// (a bias-free filter plus a bias filter). The optimal two-stage estimator is algebraically the
/// Kalman filter of the augmented state [p, v, b] (Hsieh & Chen, IEEE TAC 44(1), 1999), which is
/// what runs here: the same b̂, without the decoupling bookkeeping.

#include "imm/core/checks.hpp"
#include "imm/estimation/kalman_filter.hpp"
#include "imm/models/motion/constant_acceleration.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// The augmented-state [p, v, b] Kalman filter that estimates the acceleration bias b of one axis
/// (AIMM, seed 001 §2; see the file comment).
class IMM_RUNTIME_EXPORT AccelerationEstimator {
 public:
  /// Throws InvalidParameter naming the field: a non-positive sample period or measurement
  /// variance, a negative σ.
  AccelerationEstimator(double sample_period, double state_noise_sigma, double bias_noise_sigma,
                        double measurement_variance)
      : F_(ca_axis_transition(sample_period)), R_(SquareMatrix<1>::Constant(measurement_variance)) {
    require_positive(sample_period, "sample_period");
    require_non_negative(state_noise_sigma, "state_noise_sigma");
    require_non_negative(bias_noise_sigma, "bias_noise_sigma");
    require_positive(measurement_variance, "measurement_variance");
    const Vector<2> g = cv_axis_input_gain(sample_period);
    Q_.setZero();
    Q_.block<2, 2>(0, 0) = state_noise_sigma * state_noise_sigma * g * g.transpose();
    Q_(2, 2) = bias_noise_sigma * bias_noise_sigma;
    H_ << 1.0, 0.0, 0.0;
  }

  /// Starts from a [p, v] estimate with b = 0 of the given variance.
  void initialize(const GaussianState<2>& state, double acceleration_variance) {
    estimate_.mean << state.mean(0), state.mean(1), 0.0;
    estimate_.covariance.setZero();
    estimate_.covariance.block<2, 2>(0, 0) = state.covariance;
    estimate_.covariance(2, 2) = acceleration_variance;
  }

  /// Predicts one period and updates with z; on failure nothing changes.
  StepStatus step(double z) {
    GaussianState<3> next = predict(estimate_, F_, Q_);
    const auto report = update(next, Vector<1>(z), H_, R_);
    if (report.ok()) estimate_ = next;
    return report.status;
  }

  /// The current acceleration estimate b̂.
  [[nodiscard]] double acceleration() const { return estimate_.mean(2); }
  /// The current [p, v, b] estimate.
  [[nodiscard]] const GaussianState<3>& estimate() const { return estimate_; }
  /// Replaces the current estimate (track initialization).
  void set_estimate(const GaussianState<3>& estimate) { estimate_ = estimate; }

 private:
  SquareMatrix<3> F_;
  SquareMatrix<3> Q_;
  Matrix<1, 3> H_;
  SquareMatrix<1> R_;
  GaussianState<3> estimate_;
};

}  // namespace imm
