// SPDX-License-Identifier: Apache-2.0
#include "imm/tracking/calibrated_filter.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "imm/core/invalid_parameter.hpp"
#include "imm/io/model_file.hpp"

namespace imm {
namespace {

void check_factors(const std::vector<double>& factors, const std::string& name, std::size_t size) {
  if (factors.size() != size) {
    throw InvalidParameter(
        "calibration." + name,
        "expected " + std::to_string(size) + " entries, got " + std::to_string(factors.size()));
  }
  for (std::size_t i = 0; i < factors.size(); ++i) {
    if (!(factors[i] > 0.0) || !std::isfinite(factors[i])) {
      throw InvalidParameter("calibration." + name + "[" + std::to_string(i) + "]",
                             "must be a finite factor > 0");
    }
  }
}

// The start table's factor after `used` plots: the last entry holds on.
double factor(const std::vector<double>& start, long used) noexcept {
  return start[static_cast<std::size_t>(
      std::clamp<long>(used, 0, static_cast<long>(start.size()) - 1))];
}

}  // namespace

void CovarianceCalibration::validate() const {
  if (!(memory >= 0.0 && memory < 1.0)) {
    throw InvalidParameter("calibration.memory", "must be in [0, 1)");
  }
  if (!(nis_cap > 0.0) || !std::isfinite(nis_cap)) {
    throw InvalidParameter("calibration.nis_cap", "must be a finite number > 0");
  }
  const auto max = static_cast<std::size_t>(kMaxEntries);
  if (start_innovation.empty() || start_innovation.size() > max) {
    throw InvalidParameter("calibration.start_innovation",
                           "must have 1 to " + std::to_string(max) + " entries");
  }
  check_factors(start_state, "start_state", start_innovation.size());
  check_factors(start_innovation, "start_innovation", start_innovation.size());
  if (edges.size() >= max) {
    throw InvalidParameter("calibration.edges", "must have fewer than " + std::to_string(max));
  }
  for (std::size_t i = 0; i < edges.size(); ++i) {
    if (!std::isfinite(edges[i]) || (i > 0 && !(edges[i] > edges[i - 1]))) {
      throw InvalidParameter("calibration.edges[" + std::to_string(i) + "]",
                             "edges must be finite and strictly ascending");
    }
  }
  check_factors(level_innovation, "level_innovation", edges.size() + 1);
  check_factors(level_state, "level_state", edges.size() + 1);
}

int CovarianceCalibration::bin(double level) const noexcept {
  // The bins are [edges[i−1], edges[i]); a NaN level (none seen) falls in the first.
  return static_cast<int>(std::upper_bound(edges.begin(), edges.end(), level) - edges.begin());
}

double CovarianceCalibration::next_level(double level, double nis) const noexcept {
  return memory * level + (1.0 - memory) * std::min(nis, nis_cap);
}

double CovarianceCalibration::innovation_scale(long used, double level) const noexcept {
  return factor(start_innovation, used) * level_innovation[static_cast<std::size_t>(bin(level))];
}

double CovarianceCalibration::state_scale(long used, double level) const noexcept {
  return factor(start_state, used) * level_state[static_cast<std::size_t>(bin(level))];
}

std::shared_ptr<const CovarianceCalibration> read_calibration(const io::ModelFileReader& reader) {
  const std::string group = "/calibration";
  if (reader.container().kind(group) == io::ObjectKind::kMissing) return nullptr;
  // A reader before version 4 would ignore the group and state the model's uncalibrated
  // covariances: such a file is version 4, and an older one that holds the group is refused.
  if (reader.schema_version() < kCalibrationSchemaVersion) {
    reader.fail(group, "a version-" + std::to_string(kCalibrationSchemaVersion) +
                           " group in a file of schema version " +
                           std::to_string(reader.schema_version()));
  }
  auto calibration = std::make_shared<CovarianceCalibration>();
  calibration->memory = reader.real(group, "memory", io::ValueRule::kProbability);
  calibration->nis_cap = reader.real(group, "nis_cap", io::ValueRule::kPositive);
  const auto table = [&](const char* name) {
    const Eigen::VectorXd v = reader.vector(group + "/" + name, -1, io::ValueRule::kFinite);
    return std::vector<double>(v.data(), v.data() + v.size());
  };
  calibration->start_innovation = table("start_innovation");
  calibration->start_state = table("start_state");
  if (reader.container().kind(group + "/edges") != io::ObjectKind::kMissing) {
    calibration->edges = table("edges");
  }
  calibration->level_innovation = table("level_innovation");
  calibration->level_state = table("level_state");
  try {
    calibration->validate();
  } catch (const InvalidParameter& invalid) {
    const std::string& field = invalid.field();  // "calibration.<name>"
    reader.fail_spec(
        group, InvalidParameter(field.substr(field.find('.') + 1), invalid.what()),
        {"start_innovation", "start_state", "edges", "level_innovation", "level_state"});
  }
  return calibration;
}

CalibratedFilter::CalibratedFilter(std::unique_ptr<TrackFilter> filter,
                                   std::shared_ptr<const CovarianceCalibration> calibration)
    : filter_(std::move(filter)), calibration_(std::move(calibration)) {
  if (!filter_) throw InvalidParameter("filter", "is null");
  if (!calibration_) throw InvalidParameter("calibration", "is null");
  calibration_->validate();
  hold_scales();
}

void CalibratedFilter::hold_scales() noexcept {
  innovation_scale_ = calibration_->innovation_scale(used_, level_);
  state_scale_ = calibration_->state_scale(used_, level_);
}

void CalibratedFilter::after_update() noexcept {
  // The level follows the model's own NIS, not the calibrated one: the factors never feed back.
  if (const auto nis = last_step_nis(*filter_)) {
    level_ = calibration_->next_level(level_, *nis);
  }
  ++used_;
  state_scale_ = calibration_->state_scale(used_, level_);  // the innovation's stays the step's
}

void CalibratedFilter::initialize(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) {
  filter_->initialize(mean, covariance);
  used_ = 0;
  level_ = 2.0;
  hold_scales();
}

StepStatus CalibratedFilter::step(const Eigen::Vector2d& z) {
  hold_scales();
  const StepStatus status = filter_->step(z);
  if (status == StepStatus::kOk) after_update();
  return status;
}

StepStatus CalibratedFilter::predict_only() {
  hold_scales();
  return filter_->predict_only();
}

void CalibratedFilter::state(Eigen::Ref<Eigen::VectorXd> mean,
                             Eigen::Ref<Eigen::VectorXd> variance) const {
  filter_->state(mean, variance);
  variance *= state_scale_;
}

void CalibratedFilter::covariance(Eigen::Ref<Eigen::MatrixXd> covariance) const {
  filter_->covariance(covariance);
  covariance *= state_scale_;
}

bool CalibratedFilter::innovation(Eigen::Vector2d& nu, Eigen::Matrix2d& S) const {
  if (!filter_->innovation(nu, S)) return false;
  S *= innovation_scale_;
  return true;
}

StepStatus CalibratedFilter::predict() {
  hold_scales();
  return filter_->predict();
}

double CalibratedFilter::candidate_distance(const Eigen::Vector2d& z) const {
  return filter_->candidate_distance(z) / innovation_scale_;
}

bool CalibratedFilter::predicted_plot(Eigen::Vector2d& z_hat, Eigen::Matrix2d& S) const {
  if (!filter_->predicted_plot(z_hat, S)) return false;
  S *= innovation_scale_;
  return true;
}

StepStatus CalibratedFilter::update(const Eigen::Vector2d& z) {
  const StepStatus status = filter_->update(z);
  if (status == StepStatus::kOk) after_update();
  return status;
}

StepStatus CalibratedFilter::miss() {
  hold_scales();
  return filter_->miss();
}

}  // namespace imm
