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
  limits::require_sample_period(sample_period, "sample_period");
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
    : WimmFilter(spec, std::make_shared<AzimuthFusion>()) {}

WimmFilter::WimmFilter(const WimmSpec& spec, std::shared_ptr<AzimuthFusion> fusion)
    : ImmTrackFilter<6>(build_imm(spec, fusion)), spec_(spec), fusion_(std::move(fusion)) {}

void WimmFilter::initialize(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) {
  ImmTrackFilter<6>::initialize(mean, covariance);
  fused_ = false;
}

StepStatus WimmFilter::step(const Eigen::Vector2d& z) {
  bool fused = false;
  const AzimuthUse plain =
      spec_.update == MeasurementUpdate::kConverted ? AzimuthUse::kConverted : AzimuthUse::kPlot;
  const StepStatus status = estimator().step_with(
      z,
      [&](const ModeVector& predicted, const std::array<Vector<6>, kMaxModes>& means,
          const Vector<2>& plot) -> Vector<2> {
        Vector<2> chosen = plot;
        fusion_->use = plain;
        if (spec_.fusion != FusionVariant::kNone && predicted(0) > spec_.threshold) {
          // θ̄: the μ̄-weighted circular mean of the modes' predicted azimuths (eq. 9–11).
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
          if (spec_.fusion == FusionVariant::kCorrelated) fusion_->use = AzimuthUse::kCorrelated;
          fused = true;
        }
        if (fusion_->use == AzimuthUse::kConverted) {
          fusion_->converted_covariance =
              polar_to_cartesian(chosen, spec_.measurement_covariance()).covariance;
        }
        chosen_ = chosen;
        return chosen;
      });
  if (status == StepStatus::kOk) {
    fused_ = fused;
    plot_ = z;
    use_ = fusion_->use;
  }
  return status;
}

// Without a split cycle each call below is the interface's own answer (it throws, or answers NaN),
// not the IMM's that ImmTrackFilter would give.
// NOLINTBEGIN(bugprone-parent-virtual-call)
StepStatus WimmFilter::predict() {
  if (!has_split_cycle()) return TrackFilter::predict();  // throws
  fusion_->use = AzimuthUse::kPlot;  // what step()'s choice sets without fusion
  return estimator().predict();
}

double WimmFilter::candidate_log_likelihood(const Eigen::Vector2d& z) const {
  if (!has_split_cycle()) return TrackFilter::candidate_log_likelihood(z);
  return imm().candidate_log_likelihood(z);
}

double WimmFilter::candidate_distance(const Eigen::Vector2d& z) const {
  if (!has_split_cycle()) return TrackFilter::candidate_distance(z);
  return imm().candidate_distance(z);
}

bool WimmFilter::predicted_plot(Eigen::Vector2d& z_hat, Eigen::Matrix2d& S) const {
  return has_split_cycle() && imm().predicted_plot(z_hat, S);
}

StepStatus WimmFilter::update(const Eigen::Vector2d& z) {
  if (!has_split_cycle()) return TrackFilter::update(z);  // throws
  const StepStatus status = estimator().update(z);
  if (status == StepStatus::kOk) {  // step()'s bookkeeping of an unfused cycle
    fused_ = false;
    plot_ = z;
    chosen_ = z;
    use_ = AzimuthUse::kPlot;
  }
  return status;
}

StepStatus WimmFilter::miss() {
  if (!has_split_cycle()) return TrackFilter::miss();  // throws
  return estimator().miss();
}
// NOLINTEND(bugprone-parent-virtual-call)

void WimmFilter::to_plot(Vector<2>& nu, SquareMatrix<2>& S) const {
  if (!fused_) return;
  switch (use_) {
    case AzimuthUse::kSeed:
    case AzimuthUse::kPlot:
      // ν_θ = θ_f − ĥ_θ: the plot's is θ_p − ĥ_θ, and S does not depend on the azimuth.
      nu(1) = wrap_angle(nu(1) + wrap_angle(plot_(1) - chosen_(1)));
      return;
    case AzimuthUse::kCorrelated:
      // ν_f = A ν, S_f = A S Aᵀ with A = diag(1, α).
      nu(1) /= spec_.alpha;
      S.row(1) /= spec_.alpha;
      S.col(1) /= spec_.alpha;
      return;
    case AzimuthUse::kConverted: {
      const Eigen::Matrix2d R = spec_.measurement_covariance();
      const auto plot = polar_to_cartesian(plot_, R);
      const auto fused = polar_to_cartesian(chosen_, R);
      nu += plot.position - fused.position;
      S += plot.covariance - fused.covariance;
      return;
    }
  }
}

bool WimmFilter::innovation(Eigen::Vector2d& nu, Eigen::Matrix2d& S) const {
  Vector<2> n;
  SquareMatrix<2> s;
  if (!imm().innovation(n, s, [this](Vector<2>& v, SquareMatrix<2>& c) { to_plot(v, c); }))
    return false;
  nu = n;
  S = s;
  return true;
}

double WimmFilter::log_predictive_likelihood() const {
  const double density =
      imm().log_predictive_likelihood([this](Vector<2>& v, SquareMatrix<2>& c) { to_plot(v, c); });
  // p(r, θ) = p(x, y) · r under the converted update.
  return use_ == AzimuthUse::kConverted ? density + std::log(plot_(0)) : density;
}

}  // namespace imm
