// SPDX-License-Identifier: Apache-2.0
#include "imm/filters/fimm.hpp"

#include <cmath>

#include "imm/core/checks.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/estimation/kalman_mode.hpp"
#include "imm/models/measurement/position_measurement.hpp"
#include "imm/models/measurement/tsk_sensor_measurement.hpp"
#include "imm/models/motion/constant_acceleration.hpp"

namespace imm {
namespace {

constexpr std::array<int, 2> kPositions = {0, 3};  // ξ, η in [ξ, ξ̇, ξ̈, η, η̇, η̈]
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

FimmFilter::FimmFilter(const FimmSpec& spec, std::shared_ptr<const TskSensorModel> sensor)
    : sensor_(std::move(sensor)) {
  spec.validate();
  std::vector<std::unique_ptr<ImmMode<6, 2>>> modes;
  for (int j = 0; j < 2; ++j) {
    const auto motion = constant_acceleration<2>(spec.sample_period, spec.process_noise(j));
    if (sensor_) {
      modes.push_back(std::make_unique<KalmanMode<6, 6, TskSensorMeasurement<6>>>(
          kModeNames[j], motion,
          TskSensorMeasurement<6>(sensor_, kPositions, spec.measurement_covariance),
          StateEmbedding<6, 6>(), spec.iterations));
    } else {
      modes.push_back(std::make_unique<KalmanMode<6, 6, PositionMeasurement<6, 2>>>(
          kModeNames[j], motion, PositionMeasurement<6, 2>(kPositions, spec.measurement_covariance),
          StateEmbedding<6, 6>()));
    }
  }
  imm_ = std::make_unique<ImmEstimator<6, 2>>(std::move(modes), spec.transition,
                                              spec.initial_probabilities);
}

FimmFilter::~FimmFilter() = default;

std::string FimmFilter::mode_name(int j) const { return kModeNames[j == 0 ? 0 : 1]; }

void FimmFilter::initialize(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) {
  if (mean.size() != 6 || covariance.rows() != 6 || covariance.cols() != 6) {
    throw InvalidParameter("initial_state", "the FIMM state has 6 components");
  }
  if (!mean.allFinite()) throw InvalidParameter("initial_state", "must be finite");
  if (!covariance.allFinite() || !covariance.isApprox(covariance.transpose(), 1e-12) ||
      (covariance.diagonal().array() < 0.0).any()) {
    throw InvalidParameter("initial_covariance",
                           "must be finite and symmetric with a non-negative diagonal");
  }
  GaussianState<6> state;
  state.mean = mean;
  state.covariance = covariance;
  imm_->initialize(state);
}

StepStatus FimmFilter::step(const Eigen::Vector2d& z) { return imm_->step(z); }

StepStatus FimmFilter::predict_only() { return imm_->predict_only(); }

bool FimmFilter::predicts_before_the_plot() const { return imm_->predicts_before_the_plot(); }

StepStatus FimmFilter::predict() { return imm_->predict(); }

double FimmFilter::candidate_log_likelihood(const Eigen::Vector2d& z) const {
  return imm_->candidate_log_likelihood(z);
}

double FimmFilter::candidate_distance(const Eigen::Vector2d& z) const {
  return imm_->candidate_distance(z);
}

bool FimmFilter::predicted_plot(Eigen::Vector2d& z_hat, Eigen::Matrix2d& S) const {
  return imm_->predicted_plot(z_hat, S);
}

StepStatus FimmFilter::update(const Eigen::Vector2d& z) { return imm_->update(z); }

StepStatus FimmFilter::miss() { return imm_->miss(); }

void FimmFilter::state(Eigen::Ref<Eigen::VectorXd> mean,
                       Eigen::Ref<Eigen::VectorXd> variance) const {
  mean = imm_->estimate().mean;
  variance = imm_->estimate().covariance.diagonal();
}

void FimmFilter::covariance(
    Eigen::Ref<Eigen::MatrixXd> covariance) const {  // NOLINT(performance-unnecessary-value-param)
  covariance = imm_->estimate().covariance;
}

ModeVector FimmFilter::mode_probabilities() const { return imm_->mode_probabilities(); }

bool FimmFilter::innovation(Eigen::Vector2d& nu, Eigen::Matrix2d& S) const {
  return imm_->innovation(nu, S);
}

const GaussianState<6>& FimmFilter::estimate() const { return imm_->estimate(); }

bool FimmFilter::outside_sensor_box() const {
  if (!sensor_) return false;
  const auto& x = imm_->estimate().mean;
  return sensor_->evaluate(Eigen::Vector2d(x(0), x(3))).clamped;
}

}  // namespace imm
