// SPDX-License-Identifier: Apache-2.0
#include "imm/filters/axis_filter.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/math/log_sum_exp.hpp"

namespace imm {

void AxisImmSettings::validate() const {
  limits::require_sample_period(sample_period, "sample_period");
  limits::require_in(measurement_sigma, limits::kSigma, "measurement_sigma");
  if (!(transition_stay > 0.0 && transition_stay <= 1.0)) {
    throw InvalidParameter("transition_stay", "must be in (0, 1]");
  }
  if (!(initial_first_probability >= 0.0 && initial_first_probability <= 1.0)) {
    throw InvalidParameter("initial_first_probability", "must be in [0, 1]");
  }
}

Eigen::MatrixXd AxisImmSettings::transition(int n) const {
  if (n == 1) return Eigen::MatrixXd::Ones(1, 1);
  Eigen::MatrixXd pi = Eigen::MatrixXd::Constant(n, n, (1.0 - transition_stay) / (n - 1));
  pi.diagonal().setConstant(transition_stay);
  return pi;
}

Eigen::VectorXd AxisImmSettings::initial_probabilities(int n) const {
  if (n == 1) return Eigen::VectorXd::Ones(1);
  Eigen::VectorXd mu = Eigen::VectorXd::Constant(n, (1.0 - initial_first_probability) / (n - 1));
  mu(0) = initial_first_probability;
  return mu;
}

TrackOptions AxisImmSettings::track_options(std::int64_t max_gap) const {
  validate();
  return two_point_track_options(
      sample_period, MeasurementKind::kCartesian,
      measurement_sigma * measurement_sigma * Eigen::Matrix2d::Identity(), max_gap);
}

double axis_log_density(double nu, double variance) {
  if (!(variance > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  return axis_log_density_of(nu * nu / variance, std::log(variance));
}

double AxisFilter::log_predictive_likelihood() const {
  double nu = 0.0, variance = 0.0;
  if (!innovation(nu, variance)) return std::numeric_limits<double>::quiet_NaN();
  return axis_log_density(nu, variance);
}

namespace {
[[noreturn]] void no_axis_split(const char* call) {
  throw std::logic_error(std::string("AxisFilter::") + call +
                         ": this axis filter does not split its cycle; use step() and "
                         "predict_only()");
}
}  // namespace

StepStatus AxisFilter::predict() { no_axis_split("predict"); }
double AxisFilter::candidate_log_likelihood(double /*z*/) const {
  return std::numeric_limits<double>::quiet_NaN();
}
double AxisFilter::candidate_distance(double /*z*/) const {
  return std::numeric_limits<double>::quiet_NaN();
}
bool AxisFilter::predicted_plot(double& /*z_hat*/, double& /*variance*/) const { return false; }
StepStatus AxisFilter::update(double /*z*/) { no_axis_split("update"); }
StepStatus AxisFilter::miss() { no_axis_split("miss"); }

bool ImmAxisFilter::predicted_plot(double& z_hat, double& variance) const {
  Vector<1> mean;
  SquareMatrix<1> covariance;
  if (!imm().predicted_plot(mean, covariance)) return false;
  z_hat = mean(0);
  variance = covariance(0, 0);
  return true;
}

TwoAxisFilter::TwoAxisFilter(std::unique_ptr<AxisFilter> x, std::unique_ptr<AxisFilter> y)
    : x_(std::move(x)), y_(std::move(y)) {
  if (!x_ || !y_) throw InvalidParameter("axis", "both axis filters are required");
}

std::string TwoAxisFilter::mode_name(int j) const {
  return j < x_->mode_count() ? "x." + x_->mode_name(j)
                              : "y." + y_->mode_name(j - x_->mode_count());
}

void TwoAxisFilter::initialize(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) {
  require_initial_state(mean, covariance, 4);
  for (Eigen::Index axis = 0; axis < 2; ++axis) {
    GaussianState<2> state;
    state.mean = mean.segment<2>(2 * axis);
    state.covariance = covariance.block<2, 2>(2 * axis, 2 * axis);
    (axis == 0 ? x_ : y_)->initialize(state);
  }
}

StepStatus TwoAxisFilter::step(const Eigen::Vector2d& z) {
  if (!limits::usable_measurement(z)) return StepStatus::kInvalidMeasurement;
  return x_then_y([&](AxisFilter& axis, Eigen::Index i) { return axis.step(z(i)); });
}

StepStatus TwoAxisFilter::predict_only() {
  return x_then_y([](AxisFilter& axis, Eigen::Index) { return axis.predict_only(); });
}

StepStatus TwoAxisFilter::predict() {
  return x_then_y([](AxisFilter& axis, Eigen::Index) { return axis.predict(); });
}

bool TwoAxisFilter::predicted_plot(Eigen::Vector2d& z_hat, Eigen::Matrix2d& S) const {
  double zx = 0.0, sx = 0.0, zy = 0.0, sy = 0.0;
  if (!x_->predicted_plot(zx, sx) || !y_->predicted_plot(zy, sy)) return false;
  z_hat << zx, zy;
  S << sx, 0.0, 0.0, sy;
  return true;
}

StepStatus TwoAxisFilter::update(const Eigen::Vector2d& z) {
  if (!limits::usable_measurement(z)) return StepStatus::kInvalidMeasurement;
  return x_then_y([&](AxisFilter& axis, Eigen::Index i) { return axis.update(z(i)); });
}

StepStatus TwoAxisFilter::miss() {
  return x_then_y([](AxisFilter& axis, Eigen::Index) { return axis.miss(); });
}

void TwoAxisFilter::state(Eigen::Ref<Eigen::VectorXd> mean,
                          Eigen::Ref<Eigen::VectorXd> variance) const {
  mean.segment<2>(0) = x_->estimate().mean;
  mean.segment<2>(2) = y_->estimate().mean;
  variance.segment<2>(0) = x_->estimate().covariance.diagonal();
  variance.segment<2>(2) = y_->estimate().covariance.diagonal();
}

void TwoAxisFilter::covariance(
    Eigen::Ref<Eigen::MatrixXd> covariance) const {  // NOLINT(performance-unnecessary-value-param)
  covariance.setZero();                              // the axes are filtered independently
  covariance.block<2, 2>(0, 0) = x_->estimate().covariance;
  covariance.block<2, 2>(2, 2) = y_->estimate().covariance;
}

ModeVector TwoAxisFilter::mode_probabilities() const {
  const ModeVector x = x_->mode_probabilities(), y = y_->mode_probabilities();
  ModeVector mu(x.size() + y.size());
  mu << x, y;
  return mu;
}

bool TwoAxisFilter::innovation(Eigen::Vector2d& nu, Eigen::Matrix2d& S) const {
  double nx = 0.0, sx = 0.0, ny = 0.0, sy = 0.0;
  if (!x_->innovation(nx, sx) || !y_->innovation(ny, sy)) return false;
  nu << nx, ny;
  S << sx, 0.0, 0.0, sy;
  return true;
}

}  // namespace imm
