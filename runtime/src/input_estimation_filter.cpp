#include "imm/filters/input_estimation_filter.hpp"

#include <algorithm>

#include "imm/core/invalid_parameter.hpp"

namespace imm {

InputEstimationFilter::InputEstimationFilter(InputEstimatorModel model, const CvKfSettings& settings)
    : model_(std::move(model)),
      motion_(constant_velocity<1>(settings.sample_period, settings.process_noise)),
      G_(cv_axis_input_gain(settings.sample_period)),
      R_(SquareMatrix<1>::Constant(settings.measurement_variance)) {
  if (!(settings == model_.settings)) {
    throw InvalidParameter(
        "cv_kf", "the model's features assume T = " + std::to_string(model_.settings.sample_period) +
                     " s, q = " + std::to_string(model_.settings.process_noise) +
                     ", R = " + std::to_string(model_.settings.measurement_variance) +
                     "; the filter has T = " + std::to_string(settings.sample_period) +
                     " s, q = " + std::to_string(settings.process_noise) +
                     ", R = " + std::to_string(settings.measurement_variance));
  }
  if (model_.network.input_count() != 2) {
    throw InvalidParameter("network", "the input estimator's network takes (sum, diff)");
  }
  if (!(settings.measurement_variance > 0.0)) {
    throw InvalidParameter("cv_kf.measurement_variance", "must be positive");
  }
  H_ << 1.0, 0.0;
}

void InputEstimationFilter::initialize(const GaussianState<2>& state) {
  cv_ = state;
  primary_ = state;
  features_.reset();
  acceleration_ = 0.0;
  raw_output_ = 0.0;
  ino_ = 0.0;
}

StepStatus InputEstimationFilter::step(double z) {
  if (!std::isfinite(z)) return StepStatus::kInvalidMeasurement;
  // The plain CV KF and its normalized innovation (eq. 4–9, 11).
  GaussianState<2> cv = predict(cv_, motion_.transition, motion_.process_noise);
  const auto cv_report = update(cv, Vector<1>(z), H_, R_);
  if (!cv_report.ok()) return cv_report.status;
  // The primary KF with the input estimated at k − 1 (eq. 10).
  GaussianState<2> primary =
      predict(primary_, motion_.transition, motion_.process_noise, G_, Vector<1>(acceleration_));
  const auto primary_report = update(primary, Vector<1>(z), H_, R_);
  if (!primary_report.ok()) return primary_report.status;

  const double innovation = cv_report.innovation(0);
  ino_ = innovation * innovation / cv_report.innovation_covariance(0, 0);
  const Eigen::Vector2d features = features_.push(ino_);
  input_ = standardize(model_, features);
  raw_output_ = model_.network.forward(input_);
  acceleration_ = std::max(0.0, raw_output_ - model_.output_bias);
  cv_ = cv;
  primary_ = primary;
  return StepStatus::kOk;
}

}  // namespace imm
