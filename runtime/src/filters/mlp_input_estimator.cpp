// SPDX-License-Identifier: Apache-2.0
#include "imm/filters/mlp_input_estimator.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

#include "imm/core/enum_names.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"

namespace imm {

void CvKfSettings::validate() const {
  limits::require_sample_period(sample_period, "sample_period");
  limits::require_in(process_noise, limits::kVariance, "process_noise");
  limits::require_in(measurement_variance, {1e-18, limits::kVariance.max, ""},
                     "measurement_variance");
}

InnovationFeatureExtractor::InnovationFeatureExtractor(const CvKfSettings& settings)
    : motion_(constant_velocity<1>(settings.sample_period, settings.process_noise)),
      R_(SquareMatrix<1>::Constant(settings.measurement_variance)) {
  settings.validate();
  H_ << 1.0, 0.0;
}

namespace {
constexpr std::array kInputSignNames{EnumName<InputSign>{InputSign::kPositive, "positive"},
                                     EnumName<InputSign>{InputSign::kInnovation, "innovation"}};
}  // namespace

std::string_view to_string(InputSign sign) { return name_of(kInputSignNames, sign); }

InputSign input_sign_from(std::string_view name, const std::string& field) {
  return value_named(kInputSignNames, name, field, "sign");
}

void InnovationFeatureExtractor::initialize(const GaussianState<2>& state) {
  cv_ = state;
  features_.reset();
  innovations_.fill(0.0);
  innovation_head_ = 0;
  innovation_sum_ = 0.0;
  ino_ = 0.0;
  innovation_ = 0.0;
}

StepStatus InnovationFeatureExtractor::step(double z, Eigen::Vector2d& features) {
  if (!limits::usable_measurement(z)) return StepStatus::kInvalidMeasurement;
  GaussianState<2> cv = predict(cv_, motion_.transition, motion_.process_noise);
  const auto report = update(cv, Vector<1>(z), H_, R_);
  if (!report.ok()) return report.status;
  innovation_ = report.innovation(0);
  ino_ = innovation_ * innovation_ / report.innovation_covariance(0, 0);
  features = features_.push(ino_);
  innovation_head_ = (innovation_head_ + 1) % innovations_.size();
  innovations_[innovation_head_] = innovation_;
  innovation_sum_ = 0.0;
  for (double nu : innovations_) innovation_sum_ += nu;
  cv_ = cv;
  return StepStatus::kOk;
}

void InnovationFeatureExtractor::predict_only() {
  cv_ = predict(cv_, motion_.transition, motion_.process_noise);
}

MlpInputEstimatorFilter::MlpInputEstimatorFilter(MlpInputEstimatorModel model,
                                                 const CvKfSettings& settings)
    : model_(std::move(model)),
      motion_(constant_velocity<1>(settings.sample_period, settings.process_noise)),
      G_(cv_axis_input_gain(settings.sample_period)),
      R_(SquareMatrix<1>::Constant(settings.measurement_variance)),
      features_(settings) {
  if (!(settings == model_.settings)) {
    throw InvalidParameter(
        "cv_kf",
        "the model's features assume T = " + std::to_string(model_.settings.sample_period) +
            " s, q = " + std::to_string(model_.settings.process_noise) +
            ", R = " + std::to_string(model_.settings.measurement_variance) +
            "; the filter has T = " + std::to_string(settings.sample_period) +
            " s, q = " + std::to_string(settings.process_noise) +
            ", R = " + std::to_string(settings.measurement_variance));
  }
  if (model_.network.input_count() != 2) {
    throw InvalidParameter("network", "the input estimator's network takes (sum, diff)");
  }
  if (model_.input_variance != 0.0) {
    limits::require_in(model_.input_variance, limits::kVariance, "input_variance");
  }
  // The input's error as process noise of the primary KF: σ_û² G Gᵀ (0: the seed's filter, the
  // same numbers as without it).
  motion_.process_noise.noalias() += model_.input_variance * G_ * G_.transpose();
  H_ << 1.0, 0.0;
}

void MlpInputEstimatorFilter::initialize(const GaussianState<2>& state) {
  features_.initialize(state);
  primary_ = state;
  acceleration_ = 0.0;
  raw_output_ = 0.0;
  innovation_ = 0.0;
  updated_ = false;
}

StepStatus MlpInputEstimatorFilter::step(double z) {
  updated_ = false;
  predicted_ = false;
  if (!limits::usable_measurement(z)) return StepStatus::kInvalidMeasurement;
  // The primary KF with the input estimated at k − 1 (eq. 10).
  GaussianState<2> primary = imm::predict(primary_, motion_.transition, motion_.process_noise, G_,
                                          Vector<1>(acceleration_));
  const auto primary_report = update(primary, Vector<1>(z), H_, R_);
  if (!primary_report.ok()) return primary_report.status;
  // The plain CV KF and its features (eq. 4–9, 11–14), then û(k).
  Eigen::Vector2d features;
  const StepStatus status = features_.step(z, features);
  if (status != StepStatus::kOk) return status;
  input_ = standardize(model_, features);
  raw_output_ = model_.network.forward(input_);
  const double magnitude = std::max(0.0, raw_output_ - model_.output_bias);
  acceleration_ = model_.sign == InputSign::kInnovation && features_.innovation_sum() < 0.0
                      ? -magnitude
                      : magnitude;
  innovation_ = primary_report.innovation(0);
  innovation_variance_ = primary_report.innovation_covariance(0, 0);
  primary_ = primary;
  updated_ = true;
  return StepStatus::kOk;
}

void MlpInputEstimatorFilter::predict_only() {
  updated_ = false;
  predicted_ = false;
  primary_ = imm::predict(primary_, motion_.transition, motion_.process_noise, G_,
                          Vector<1>(acceleration_));
  features_.predict_only();
}

void MlpInputEstimatorFilter::predict() {
  updated_ = false;
  held_ = imm::predict(primary_, motion_.transition, motion_.process_noise, G_,
                       Vector<1>(acceleration_));
  predicted_ = true;
}

bool MlpInputEstimatorFilter::candidate_innovation(double z, double& nu, double& variance) const {
  Vector<1> innovation;
  SquareMatrix<1> covariance;
  if (!predicted_ || !score_candidate(held_, Vector<1>(z), H_, R_, innovation, covariance)) {
    return false;
  }
  nu = innovation(0);
  variance = covariance(0, 0);
  return true;
}

bool MlpInputEstimatorFilter::predicted_plot(double& z_hat, double& variance) const {
  Vector<1> mean;
  SquareMatrix<1> covariance;
  if (!predicted_ || !imm::predict_plot(held_, H_, R_, mean, covariance)) return false;
  z_hat = mean(0);
  variance = covariance(0, 0);
  return true;
}

namespace {
void require_held(const MlpInputEstimatorFilter& filter, const char* call) {
  if (!filter.predicted()) {
    throw std::logic_error(std::string("MlpInputEstimatorAxis::") + call + " without predict()");
  }
}
}  // namespace

StepStatus MlpInputEstimatorAxis::predict() {
  filter_.predict();
  return StepStatus::kOk;
}

double MlpInputEstimatorAxis::candidate_log_likelihood(double z) const {
  double nu = 0.0, variance = 0.0;
  if (!filter_.candidate_innovation(z, nu, variance)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return axis_log_density(nu, variance);
}

double MlpInputEstimatorAxis::candidate_distance(double z) const {
  double nu = 0.0, variance = 0.0;
  if (!filter_.candidate_innovation(z, nu, variance) || !(variance > 0.0)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return nu * nu / variance;
}

StepStatus MlpInputEstimatorAxis::update(double z) {
  require_held(filter_, "update");
  const StepStatus status = filter_.step(z);
  // A refused plot leaves the prediction held, for another plot or miss().
  if (status != StepStatus::kOk) filter_.predict();
  return status;
}

StepStatus MlpInputEstimatorAxis::miss() {
  require_held(filter_, "miss");
  filter_.predict_only();
  return StepStatus::kOk;
}

TrackOptions MlpInputEstimatorModel::track_options(std::int64_t max_gap) const {
  settings.validate();
  return two_point_track_options(settings.sample_period, MeasurementKind::kCartesian,
                                 settings.measurement_variance * Eigen::Matrix2d::Identity(),
                                 max_gap);
}

std::unique_ptr<TwoAxisFilter> make_mlp_input_estimator_filter(
    const MlpInputEstimatorModel& model) {
  return std::make_unique<TwoAxisFilter>(
      std::make_unique<MlpInputEstimatorAxis>(model, model.settings),
      std::make_unique<MlpInputEstimatorAxis>(model, model.settings));
}

}  // namespace imm
