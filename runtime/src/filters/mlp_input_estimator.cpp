// SPDX-License-Identifier: Apache-2.0
#include "imm/filters/mlp_input_estimator.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

#include "imm/core/enum_names.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "input_estimator_step.hpp"

namespace imm {

void CvKfSettings::validate() const {
  limits::require_sample_period(sample_period, "sample_period");
  limits::require_in(process_noise, limits::kVariance, "process_noise");
  limits::require_in(measurement_variance, {1e-18, limits::kVariance.max, ""},
                     "measurement_variance");
}

namespace {
namespace scan = input_estimator;

// [x0, x1] and [[p00, p01], [p01, p11]] of the estimate in `slots` from `first`.
GaussianState<2> estimate_in(const std::array<double, scan::kSlots>& slots, int first) {
  GaussianState<2> e;
  e.mean << slots[first], slots[first + 1];
  e.covariance << slots[first + 2], slots[first + 3], slots[first + 3], slots[first + 4];
  return e;
}

std::array<double, 5> entries_of(const GaussianState<2>& state) {
  return {state.mean(0), state.mean(1), state.covariance(0, 0), state.covariance(0, 1),
          state.covariance(1, 1)};
}

// One filter's scan (a block of one lane), its network over the units in the widest vectors the
// CPU has.
[[gnu::flatten]] IMM_VECTOR_CLONES void scan_one(const scan::Constants& b, double* slots, double z,
                                                 double& code, double* work,
                                                 scan::ScanReport<1>& report) {
  const double stepped = 1.0;
  scan::scan<1, false>(b, slots, 1, &z, &stepped, &code, work, &report);
}

// A slot of `slots` by index, as the scan's functions read them.
auto slot_of(std::array<double, scan::kSlots>& slots) {
  return [&slots](int entry) -> double& { return slots[static_cast<std::size_t>(entry)]; };
}
}  // namespace

InnovationFeatureExtractor::InnovationFeatureExtractor(const CvKfSettings& settings) {
  settings.validate();
  constants_ = scan::feature_constants(settings);
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
  scan::start(slot_of(slots_), entries_of(state));
  cv_ = estimate_in(slots_, scan::kCv);
  innovation_sum_ = 0.0;
  ino_ = 0.0;
  innovation_ = 0.0;
}

StepStatus InnovationFeatureExtractor::step(double z, Eigen::Vector2d& features) {
  if (!limits::usable_measurement(z)) return StepStatus::kInvalidMeasurement;
  auto at = slot_of(slots_);
  const scan::FeatureScan f = scan::feature_scan(constants_, at, z);
  if (f.cv.code != scan::kOk) return bank::status_of(f.cv.code);
  const double cv[5] = {f.cv.e.x0, f.cv.e.x1, f.cv.e.p00, f.cv.e.p01, f.cv.e.p11};
  scan::keep_features(at, cv, f.ino, f.head, f.cv.nu, true);
  features = {f.sum, f.diff};
  innovation_ = f.cv.nu;
  ino_ = f.ino;
  innovation_sum_ = f.nu_sum;
  cv_ = estimate_in(slots_, scan::kCv);
  return StepStatus::kOk;
}

void InnovationFeatureExtractor::predict_only() {
  scan::coast_features(constants_, slot_of(slots_));
  cv_ = estimate_in(slots_, scan::kCv);
}

MlpInputEstimatorFilter::MlpInputEstimatorFilter(MlpInputEstimatorModel model,
                                                 const CvKfSettings& settings)
    : model_(std::move(model)), R_(SquareMatrix<1>::Constant(settings.measurement_variance)) {
  settings.validate();
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
  // The scan's constants: among them the input's error as process noise of the primary KF,
  // σ_û² G Gᵀ (0: the seed's filter, the same numbers as without it).
  constants_ = std::make_shared<const scan::Constants>(model_);
  work_.assign(2 * static_cast<std::size_t>(constants_->widest), 0.0);
  H_ << 1.0, 0.0;
}

void MlpInputEstimatorFilter::mirror() {
  primary_ = estimate_in(slots_, scan::kPrimary);
  cv_ = estimate_in(slots_, scan::kCv);
  acceleration_ = slots_[scan::kInput];
}

void MlpInputEstimatorFilter::initialize(const GaussianState<2>& state) {
  scan::start(slot_of(slots_), entries_of(state));
  mirror();
  raw_output_ = 0.0;
  cv_innovation_ = 0.0;
  innovation_ = 0.0;
  updated_ = false;
  predicted_ = false;
}

StepStatus MlpInputEstimatorFilter::step(double z) {
  updated_ = false;
  predicted_ = false;
  if (!limits::usable_measurement(z)) return StepStatus::kInvalidMeasurement;
  // The scan of one lane (input_estimator_step.hpp): the primary KF with û(k − 1) (eq. 10), the
  // plain CV KF and its features (eq. 4–9, 11–14), the network, û(k); committed only where kOk.
  double code = scan::kOk;
  scan::ScanReport<1> report{};
  scan_one(*constants_, slots_.data(), z, code, work_.data(), report);
  if (code != scan::kOk) return bank::status_of(code);
  mirror();
  input_ << report.input[0][0], report.input[1][0];
  raw_output_ = report.raw[0];
  cv_innovation_ = report.cv_nu[0];
  innovation_ = report.nu[0];
  innovation_variance_ = report.s[0];
  updated_ = true;
  return StepStatus::kOk;
}

void MlpInputEstimatorFilter::predict_only() {
  updated_ = false;
  predicted_ = false;
  auto at = slot_of(slots_);
  scan::put_estimate(at, scan::kPrimary, scan::primary_prediction(*constants_, at));
  scan::coast_features(constants_->cv, at);
  mirror();
}

void MlpInputEstimatorFilter::predict() {
  updated_ = false;
  held_ = scan::held_prediction(*constants_, slot_of(slots_));
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
