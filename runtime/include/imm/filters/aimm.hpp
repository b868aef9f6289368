// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The adaptive IMM baseline of seed 000 §2.2 (Munir & Atherton; SPEC §4.2), one axis:
/// an acceleration estimate â from the two-stage (bias) estimator (acceleration_estimator.hpp),
/// and sub-models that are constant-velocity KFs driven by the inputs â(k−1), â(k−1) ± ε_i
/// (eq. 3, 7-1). AIMM3: ε = {0.04}; AIMM5: ε = {0.02, 0.04} km/s².

#include <memory>
#include <vector>

#include "imm/estimation/input_kalman_mode.hpp"
#include "imm/filters/acceleration_estimator.hpp"
#include "imm/filters/axis_filter.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// The adaptive IMM of one axis (seed 001): sub-models at the estimated acceleration and at ± the
/// intervals around it.
struct IMM_RUNTIME_EXPORT AimmSpec {
  /// Sample period, plot σ and mode switching of the axis IMM.
  AxisImmSettings settings;
  std::vector<double> intervals = {0.04};  ///< ε_i > 0; the modes are â, â ± ε_1, â ± ε_2, …
  double process_noise_sigma = 0.001;      ///< sub-models' and bias-free filter's σ_w
  double bias_noise_sigma = 0.01;          ///< the bias filter's σ_b
  double acceleration_variance = 1e-4;     ///< initial variance of â

  /// Throws InvalidParameter naming the field.
  void validate() const;
  /// 1 + 2 × the number of intervals.
  [[nodiscard]] int mode_count() const { return 1 + 2 * static_cast<int>(intervals.size()); }
  /// Cartesian plots, two-point initialization (AxisImmSettings::track_options).
  [[nodiscard]] TrackOptions track_options(std::int64_t max_gap = kDefaultMaxGap) const {
    return settings.track_options(max_gap);
  }
};

/// The adaptive IMM (AimmSpec) as one axis of a TwoAxisFilter.
class IMM_RUNTIME_EXPORT AimmAxisFilter final : public AxisFilter {
 public:
  /// Throws InvalidParameter naming the field of an invalid spec.
  explicit AimmAxisFilter(const AimmSpec& spec);

  /// Starts the sub-models and the acceleration estimator from `state`.
  void initialize(const GaussianState<2>& state) override;
  StepStatus step(double z) override;
  /// One cycle without a measurement.
  StepStatus predict_only() override;
  /// The combined [p, v] estimate.
  [[nodiscard]] const GaussianState<2>& estimate() const override { return imm_.estimate(); }
  /// The mode probabilities, in mode order.
  [[nodiscard]] ModeVector mode_probabilities() const override { return imm_.mode_probabilities(); }
  /// The number of sub-models.
  [[nodiscard]] int mode_count() const override { return imm_.mode_count(); }
  /// The name of sub-model j.
  [[nodiscard]] std::string mode_name(int j) const override;
  /// The IMM's combined innovation.
  bool innovation(double& nu, double& variance) const override;
  /// The IMM's mixture log Σ_j c_j N(ν_j; 0, S_j).
  [[nodiscard]] double log_predictive_likelihood() const override {
    return imm_.log_predictive_likelihood();
  }
  /// The current acceleration estimate â(k).
  [[nodiscard]] double acceleration() const { return estimator_.acceleration(); }

 private:
  void set_inputs();

  AimmSpec spec_;
  std::vector<double> offsets_;          // 0, +ε₁, −ε₁, …
  std::vector<InputKalmanMode*> modes_;  // owned by imm_
  ImmEstimator<2, 1> imm_;
  AccelerationEstimator estimator_;
};

/// The 2-D adaptive IMM (AIMM per axis).
[[nodiscard]] IMM_RUNTIME_EXPORT std::unique_ptr<TwoAxisFilter> make_aimm_filter(
    const AimmSpec& spec);

}  // namespace imm
