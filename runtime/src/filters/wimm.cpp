// SPDX-License-Identifier: Apache-2.0
#include "imm/filters/wimm.hpp"

#include <array>
#include <cmath>

#include "imm/core/checks.hpp"
#include "imm/core/enum_names.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/estimation/kalman_mode.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/models/motion/singer.hpp"

namespace imm {
namespace {

ImmEstimator<6, 2> build_imm(const WimmSpec& spec,
                             const std::shared_ptr<const AzimuthFusion>& fusion) {
  spec.validate();
  const Eigen::Matrix2d R = spec.measurement_covariance();
  std::vector<std::unique_ptr<ImmMode<6, 2>>> modes;
  modes.push_back(std::make_unique<KalmanMode<6, 4, FusedPolarMeasurement<4>>>(
      "cv", constant_velocity<2>(spec.sample_period, spec.cv_process_noise),
      FusedPolarMeasurement<4>(0, 2, R, fusion),
      StateEmbedding<4, 6>(std::array<int, 4>{0, 1, 3, 4})));
  modes.push_back(std::make_unique<KalmanMode<6, 6, FusedPolarMeasurement<6>>>(
      "singer", singer<2>(spec.sample_period, spec.singer_tau, spec.singer_sigma),
      FusedPolarMeasurement<6>(0, 3, R, fusion), StateEmbedding<6, 6>()));
  return {std::move(modes), spec.transition, spec.initial_probabilities};
}

}  // namespace

namespace {
constexpr std::array kFusionVariantNames{
    EnumName<FusionVariant>{FusionVariant::kNone, "none"},
    EnumName<FusionVariant>{FusionVariant::kSeed, "seed"},
    EnumName<FusionVariant>{FusionVariant::kCorrelated, "correlated"}};
constexpr std::array kMeasurementUpdateNames{
    EnumName<MeasurementUpdate>{MeasurementUpdate::kExtended, "extended"},
    EnumName<MeasurementUpdate>{MeasurementUpdate::kConverted, "converted"}};
}  // namespace

std::string_view to_string(FusionVariant variant) { return name_of(kFusionVariantNames, variant); }

std::string_view to_string(MeasurementUpdate update) {
  return name_of(kMeasurementUpdateNames, update);
}

FusionVariant fusion_variant_from(std::string_view name, const std::string& field) {
  return value_named(kFusionVariantNames, name, field, "fusion");
}

MeasurementUpdate measurement_update_from(std::string_view name, const std::string& field) {
  return value_named(kMeasurementUpdateNames, name, field, "measurement update");
}

void WimmSpec::validate() const {
  limits::require_in(sample_period, limits::kSamplePeriod, "sample_period");
  limits::require_in(cv_process_noise, limits::kVariance, "cv_process_noise");
  limits::require_in(singer_tau, limits::kTimeConstant, "singer_tau");
  limits::require_in(singer_sigma, limits::kAcceleration, "singer_sigma");
  limits::require_in(range_sigma, limits::kSigma, "range_sigma");
  limits::require_in(azimuth_sigma, {1e-9, 3.2, "rad"}, "azimuth_sigma");
  validate_mode_probabilities(transition, initial_probabilities, 2);
  // Compared with a predicted probability: 0 fuses on every scan, 1 on none.
  require(threshold >= 0.0 && threshold <= 1.0, "threshold", "must be in [0, 1]");
  require(alpha > 0.0 && alpha <= 1.0, "alpha", "must be in (0, 1]");
  require(!(fusion == FusionVariant::kCorrelated && update == MeasurementUpdate::kConverted),
          "fusion", "the correlated fusion needs the extended (polar) update");
  limits::require_in(acceleration_variance, limits::kVariance, "acceleration_variance");
}

Eigen::Matrix2d WimmSpec::measurement_covariance() const {
  return Eigen::Vector2d(range_sigma * range_sigma, azimuth_sigma * azimuth_sigma).asDiagonal();
}

TrackOptions WimmSpec::track_options(std::int64_t max_gap) const {
  validate();
  return two_point_track_options(sample_period, MeasurementKind::kPolar, measurement_covariance(),
                                 max_gap, acceleration_variance);
}

WimmFilter::WimmFilter(const WimmSpec& spec)
    : spec_(spec), fusion_(std::make_shared<AzimuthFusion>()), imm_(build_imm(spec, fusion_)) {}

void WimmFilter::initialize(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) {
  GaussianState<6> state;
  state.mean = mean;
  state.covariance = covariance;
  imm_.initialize(state);
  fused_ = false;
}

StepStatus WimmFilter::step(const Eigen::Vector2d& z) {
  bool fused = false;
  const AzimuthUse plain =
      spec_.update == MeasurementUpdate::kConverted ? AzimuthUse::kConverted : AzimuthUse::kPlot;
  const StepStatus status =
      imm_.step_with(z,
                     [&](const ModeVector& predicted, const std::array<Vector<6>, kMaxModes>& means,
                         const Vector<2>& plot) -> Vector<2> {
                       Vector<2> chosen = plot;
                       fusion_->use = plain;
                       if (spec_.fusion != FusionVariant::kNone && predicted(0) > spec_.threshold) {
                         // θ̄: the μ̄-weighted circular mean of the modes' predicted azimuths (eq.
                         // 9–11).
                         double s = 0.0, c = 0.0;
                         for (int j = 0; j < 2; ++j) {
                           const double theta = azimuth_of(means[static_cast<std::size_t>(j)](0),
                                                           means[static_cast<std::size_t>(j)](3));
                           s += predicted(j) * std::sin(theta);
                           c += predicted(j) * std::cos(theta);
                         }
                         const double theta_bar = std::atan2(s, c);
                         chosen(1) = blend_angles(plot(1), theta_bar, spec_.alpha);
                         fusion_->alpha = spec_.alpha;
                         fusion_->predicted_azimuth = theta_bar;
                         if (spec_.fusion == FusionVariant::kCorrelated)
                           fusion_->use = AzimuthUse::kCorrelated;
                         fused = true;
                       }
                       if (fusion_->use == AzimuthUse::kConverted) {
                         fusion_->converted_covariance =
                             polar_to_cartesian(chosen, spec_.measurement_covariance()).covariance;
                       }
                       return chosen;
                     });
  if (status == StepStatus::kOk) fused_ = fused;
  return status;
}

StepStatus WimmFilter::predict_only() { return imm_.predict_only(); }

bool WimmFilter::innovation(Eigen::Vector2d& nu, Eigen::Matrix2d& S) const {
  return imm_.innovation(nu, S);
}

void WimmFilter::state(
    Eigen::Ref<Eigen::VectorXd> mean,              // NOLINT(performance-unnecessary-value-param)
    Eigen::Ref<Eigen::VectorXd> variance) const {  // NOLINT(performance-unnecessary-value-param)
  mean = imm_.estimate().mean;
  variance = imm_.estimate().covariance.diagonal();
}

void WimmFilter::covariance(
    Eigen::Ref<Eigen::MatrixXd> covariance) const {  // NOLINT(performance-unnecessary-value-param)
  covariance = imm_.estimate().covariance;
}

}  // namespace imm
