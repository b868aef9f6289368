// SPDX-License-Identifier: Apache-2.0
// The per-axis filters of seed 000: GA-fuzzy IMM, adaptive IMM, constant-q IMM.
#include <cmath>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/filters/aimm.hpp"
#include "imm/filters/axis_cv_imm.hpp"
#include "imm/filters/fuzzy_noise_filter.hpp"
#include "imm/filters/ga_fuzzy_imm.hpp"
#include "imm/filters/kalman_mode.hpp"
#include "imm/models/position_measurement.hpp"

namespace imm {

// --- GA-fuzzy IMM ----------------------------------------------------------------------------

void GaFuzzyImmSpec::validate() const {
  settings.validate();
  if (levels.empty() || levels.size() > 8) throw InvalidParameter("levels", "need 1 to 8 levels");
  for (std::size_t i = 0; i < levels.size(); ++i) {
    const std::string field = "levels[" + std::to_string(i) + "]";
    if (levels[i].name.empty()) throw InvalidParameter(field + ".name", "must not be empty");
    limits::require_in(levels[i].maneuver_level, limits::kAcceleration, field + ".maneuver_level");
    if (levels[i].table.size() == 0) throw InvalidParameter(field + ".rules", "table is empty");
  }
}

ImmEstimator<2, 1> build_ga_fuzzy_axis_imm(const GaFuzzyImmSpec& spec) {
  spec.validate();
  const AxisImmSettings& s = spec.settings;
  std::vector<std::unique_ptr<ImmMode<2, 1>>> modes;
  modes.reserve(spec.levels.size());
  for (const FuzzyLevel& level : spec.levels) {
    modes.push_back(std::make_unique<FuzzyNoiseMode>(
        level.name,
        FuzzyNoiseFilter(level.table, s.sample_period, s.measurement_sigma * s.measurement_sigma)));
  }
  const int n = static_cast<int>(modes.size());
  return {std::move(modes), s.transition(n), s.initial_probabilities(n)};
}

std::unique_ptr<TwoAxisFilter> make_ga_fuzzy_imm_filter(const GaFuzzyImmSpec& spec) {
  return std::make_unique<TwoAxisFilter>(
      std::make_unique<ImmAxisFilter>(build_ga_fuzzy_axis_imm(spec)),
      std::make_unique<ImmAxisFilter>(build_ga_fuzzy_axis_imm(spec)));
}

// --- Adaptive IMM ----------------------------------------------------------------------------

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

StepStatus AimmAxisFilter::predict_only() {
  set_inputs();
  return imm_.predict_only();
}

std::unique_ptr<TwoAxisFilter> make_aimm_filter(const AimmSpec& spec) {
  return std::make_unique<TwoAxisFilter>(std::make_unique<AimmAxisFilter>(spec),
                                         std::make_unique<AimmAxisFilter>(spec));
}

// --- Constant-q IMM --------------------------------------------------------------------------

void AxisCvImmSpec::validate() const {
  settings.validate();
  if (process_noise.empty() || process_noise.size() > 8) {
    throw InvalidParameter("process_noise", "need 1 to 8 levels");
  }
  for (std::size_t i = 0; i < process_noise.size(); ++i) {
    limits::require_in(process_noise[i], limits::kVariance,
                       "process_noise[" + std::to_string(i) + "]");
  }
}

ImmEstimator<2, 1> build_axis_cv_imm(const AxisCvImmSpec& spec) {
  spec.validate();
  const AxisImmSettings& s = spec.settings;
  using Measurement = PositionMeasurement<2, 1>;
  const Measurement measurement(
      {0}, SquareMatrix<1>::Constant(s.measurement_sigma * s.measurement_sigma));
  std::vector<std::unique_ptr<ImmMode<2, 1>>> modes;
  modes.reserve(spec.process_noise.size());
  for (double q : spec.process_noise) {
    char name[32];
    std::snprintf(name, sizeof name, "q%.3g", q);
    modes.push_back(std::make_unique<KalmanMode<2, 2, Measurement>>(
        name, constant_velocity<1>(s.sample_period, q), measurement, StateEmbedding<2, 2>()));
  }
  const int n = static_cast<int>(modes.size());
  return {std::move(modes), s.transition(n), s.initial_probabilities(n)};
}

std::unique_ptr<TwoAxisFilter> make_axis_cv_imm_filter(const AxisCvImmSpec& spec) {
  return std::make_unique<TwoAxisFilter>(std::make_unique<ImmAxisFilter>(build_axis_cv_imm(spec)),
                                         std::make_unique<ImmAxisFilter>(build_axis_cv_imm(spec)));
}

}  // namespace imm
