// SPDX-License-Identifier: Apache-2.0
// The adaptive IMM of seed 000 §2.2 (Munir & Atherton): one axis.
#include "imm/filters/aimm.hpp"

#include <cmath>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/estimation/kalman_mode.hpp"
#include "imm/models/measurement/position_measurement.hpp"
#include "imm/models/motion/constant_velocity.hpp"

namespace imm {

void AimmSpec::validate() const {
  settings.validate();
  if (intervals.empty() || intervals.size() > 7) {
    throw InvalidParameter("intervals", "need 1 to 7 acceleration intervals");
  }
  for (std::size_t i = 0; i < intervals.size(); ++i) {
    require(intervals[i] > 0.0, "intervals[" + std::to_string(i) + "]", "must be positive");
    limits::require_in(intervals[i], limits::kAcceleration, "intervals[" + std::to_string(i) + "]");
  }
  limits::require_in(process_noise_sigma, limits::kAcceleration, "process_noise_sigma");
  limits::require_in(bias_noise_sigma, limits::kAcceleration, "bias_noise_sigma");
  limits::require_in(acceleration_variance, limits::kVariance, "acceleration_variance");
}

namespace {
ImmEstimator<2, 1> build_aimm_imm(const AimmSpec& spec, const std::vector<double>& offsets,
                                  std::vector<InputKalmanMode*>& raw) {
  spec.validate();
  const AxisImmSettings& s = spec.settings;
  std::vector<std::unique_ptr<ImmMode<2, 1>>> modes;
  modes.reserve(offsets.size());
  for (double offset : offsets) {
    char name[32];
    std::snprintf(name, sizeof name, "a%+g", offset);
    auto mode = std::make_unique<InputKalmanMode>(
        name, s.sample_period, spec.process_noise_sigma * spec.process_noise_sigma,
        s.measurement_sigma * s.measurement_sigma);
    raw.push_back(mode.get());
    modes.push_back(std::move(mode));
  }
  const int n = static_cast<int>(modes.size());
  return {std::move(modes), s.transition(n), s.initial_probabilities(n)};
}

std::vector<double> aimm_offsets(const AimmSpec& spec) {
  std::vector<double> offsets = {0.0};
  for (double epsilon : spec.intervals) {
    offsets.push_back(epsilon);
    offsets.push_back(-epsilon);
  }
  return offsets;
}
}  // namespace

AimmAxisFilter::AimmAxisFilter(const AimmSpec& spec)
    : spec_(spec),
      offsets_(aimm_offsets(spec)),
      imm_(build_aimm_imm(spec, offsets_, modes_)),
      estimator_(spec.settings.sample_period, spec.process_noise_sigma, spec.bias_noise_sigma,
                 spec.settings.measurement_sigma * spec.settings.measurement_sigma) {}

std::string AimmAxisFilter::mode_name(int j) const { return std::string(imm_.mode(j).name()); }

void AimmAxisFilter::set_inputs() {
  for (std::size_t j = 0; j < modes_.size(); ++j) {
    modes_[j]->set_input(estimator_.acceleration() + offsets_[j]);
  }
}

void AimmAxisFilter::initialize(const GaussianState<2>& state) {
  imm_.initialize(state);
  estimator_.initialize(state, spec_.acceleration_variance);
}

// Eq. (7-1): the sub-models use â(k−1); the estimator then takes z(k) for â(k).
StepStatus AimmAxisFilter::step(double z) {
  set_inputs();
  const GaussianState<3> estimator_before = estimator_.estimate();
  const StepStatus estimator_status = estimator_.step(z);
  if (estimator_status != StepStatus::kOk) return estimator_status;
  const StepStatus status = imm_.step(Vector<1>(z));
  if (status != StepStatus::kOk) estimator_.set_estimate(estimator_before);
  return status;
}

bool AimmAxisFilter::innovation(double& nu, double& variance) const {
  return axis_innovation(imm_, nu, variance);
}

StepStatus AimmAxisFilter::predict_only() {
  set_inputs();
  return imm_.predict_only();
}

std::unique_ptr<TwoAxisFilter> make_aimm_filter(const AimmSpec& spec) {
  return std::make_unique<TwoAxisFilter>(std::make_unique<AimmAxisFilter>(spec),
                                         std::make_unique<AimmAxisFilter>(spec));
}

}  // namespace imm
