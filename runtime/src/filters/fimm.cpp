// SPDX-License-Identifier: Apache-2.0
#include "imm/filters/fimm.hpp"

#include <cmath>

#include "fimm_step.hpp"
#include "imm/core/checks.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "position_kalman_mode.hpp"

namespace imm {
namespace {

constexpr const char* kModeNames[2] = {"cruise", "lane change"};

}  // namespace

void FimmSpec::validate() const {
  limits::require_sample_period(sample_period, "sample_period");
  limits::require_in(cruise_sigma, limits::kSigma, "cruise_sigma");
  limits::require_in(lane_change_ratio, {1.0, limits::kFactor.max, ""}, "lane_change_ratio");
  limits::require_in(noise_scale, {1e-9, limits::kFactor.max, ""}, "noise_scale");
  limits::require_in(noise_scale * cruise_sigma * lane_change_ratio, limits::kSigma,
                     "cruise_sigma × noise_scale × lane_change_ratio");
  validate_mode_probabilities(transition, initial_probabilities, 2);
  const Eigen::Matrix2d& R = measurement_covariance;
  if (!R.allFinite() || !(R(0, 0) > 0.0) || !(R.determinant() > 0.0) ||
      !(R.diagonal().maxCoeff() <= limits::kVariance.max) ||
      std::abs(R(0, 1) - R(1, 0)) > 1e-12 * R.norm()) {
    throw InvalidParameter("measurement_covariance", "must be symmetric positive definite");
  }
  if (iterations < 1 || iterations > 100) {
    throw InvalidParameter("iterations", "must be in [1, 100]");
  }
  limits::require_in(acceleration_variance, limits::kVariance, "acceleration_variance");
}

TrackOptions FimmSpec::track_options(std::int64_t max_gap) const {
  validate();
  return two_point_track_options(sample_period, MeasurementKind::kCartesian, measurement_covariance,
                                 max_gap, acceleration_variance);
}

double FimmSpec::process_noise(int mode) const {
  const double sigma = noise_scale * cruise_sigma * (mode == 0 ? 1.0 : lane_change_ratio);
  return sigma * sigma;
}

namespace {

// How a FIMM mode measures: fimm_step.hpp's linearization and update over one lane.
struct FimmMeasure {
  std::shared_ptr<const fimm::Constants> constants;

  void linearize(const Vector<2>& z, const fimm::Mode<1>& mode, bank::Linearization<1>& g) const {
    fimm::linearize<1>(*constants, z.data(), z.data() + 1, mode, mode.x, g);  // at x⁻: the EKF
  }
  void update(const Vector<2>& z, fimm::Mode<1>& mode) const {
    fimm::update<1>(*constants, z.data(), z.data() + 1, mode);
  }
};

// The two CA modes through the sensor (or h = identity), after the spec is checked.
ImmEstimator<6, 2> build_fimm(const FimmSpec& spec,
                              const std::shared_ptr<const TskSensorModel>& sensor) {
  spec.validate();
  auto constants = std::make_shared<const fimm::Constants>(fimm::constants_of(spec, sensor.get()));
  std::vector<std::unique_ptr<ImmMode<6, 2>>> modes;
  for (std::size_t j = 0; j < 2; ++j) {
    modes.push_back(std::make_unique<PositionKalmanMode<fimm::kAxis, FimmMeasure>>(
        kModeNames[j], constants->modes[j], FimmMeasure{constants}));
  }
  return {std::move(modes), spec.transition, spec.initial_probabilities};
}

}  // namespace

FimmFilter::FimmFilter(const FimmSpec& spec, std::shared_ptr<const TskSensorModel> sensor)
    : ImmTrackFilter<6>(build_fimm(spec, sensor)), sensor_(std::move(sensor)) {}

std::string FimmFilter::mode_name(int j) const { return kModeNames[j == 0 ? 0 : 1]; }

bool FimmFilter::outside_sensor_box() const {
  if (!sensor_) return false;
  const auto& x = estimate().mean;
  return sensor_->evaluate(Eigen::Vector2d(x(0), x(3))).clamped;
}

}  // namespace imm
