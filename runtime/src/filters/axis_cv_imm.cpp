// SPDX-License-Identifier: Apache-2.0
// A per-axis IMM of constant-velocity Kalman modes with constant process noises.
#include "imm/filters/axis_cv_imm.hpp"

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/estimation/kalman_mode.hpp"
#include "imm/models/measurement/position_measurement.hpp"
#include "imm/models/motion/constant_velocity.hpp"

namespace imm {

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
