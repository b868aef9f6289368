// SPDX-License-Identifier: Apache-2.0
#include "imm/calibrated_track_bank.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "imm/core/invalid_parameter.hpp"
#include "tracking/bank_checks.hpp"

namespace imm {

CalibratedTrackBank::CalibratedTrackBank(std::unique_ptr<AnyTrackBank> bank,
                                         std::shared_ptr<const CovarianceCalibration> calibration)
    : bank_(std::move(bank)), calibration_(std::move(calibration)) {
  if (!bank_) throw InvalidParameter("bank", "is null");
  if (!bank_->states_step_nis()) {
    throw InvalidParameter("bank", "does not state its steps' NIS (states_step_nis() is false)");
  }
  if (!calibration_) throw InvalidParameter("calibration", "is null");
  calibration_->validate();
  const std::size_t n = bank_->capacity();
  used_.assign(n, 0);
  level_.assign(n, 2.0);
  nis_.assign(n, 0.0);
  scale_.assign(n, 1.0);
}

std::size_t CalibratedTrackBank::checked(std::size_t track) const {
  return bank::checked_track(track, used_.size());
}

void CalibratedTrackBank::initialize(std::size_t track, const Eigen::VectorXd& mean,
                                     const Eigen::MatrixXd& covariance) {
  const std::size_t t = checked(track);
  bank_->initialize(track, mean, covariance);
  used_[t] = 0;
  level_[t] = 2.0;
}

void CalibratedTrackBank::step(std::span<const Eigen::Vector2d> plots,
                               std::span<StepStatus> status) {
  if (plots.size() > nis_.size()) {  // the wrapped bank names the sizes
    bank_->step(plots, status);
    return;
  }
  step(plots, status, std::span<double>(nis_.data(), plots.size()));
}

void CalibratedTrackBank::step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status,
                               std::span<double> nis) {
  bank_->step(plots, status, nis);
  follow(status.first(plots.size()), nis);
}

void CalibratedTrackBank::follow(std::span<const StepStatus> status, std::span<const double> nis) {
  // CalibratedFilter::after_update: the level follows the model's own NIS, then one plot more.
  for (std::size_t t = 0; t < status.size(); ++t) {
    if (status[t] != StepStatus::kOk) continue;
    if (!std::isnan(nis[t])) level_[t] = calibration_->next_level(level_[t], nis[t]);
    ++used_[t];
  }
}

void CalibratedTrackBank::estimate(std::size_t track, Eigen::VectorXd& mean,
                                   Eigen::MatrixXd& covariance) const {
  bank_->estimate(track, mean, covariance);
  covariance *= state_scale(track);
}

void CalibratedTrackBank::candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots,
                                                    double gate, Eigen::Ref<Eigen::MatrixXd> out) {
  const auto rows = static_cast<std::size_t>(std::max<Eigen::Index>(out.rows(), 0));
  if (rows > used_.size()) {  // the wrapped bank names the sizes
    bank_->candidate_log_likelihoods(plots, gate, out);
    return;
  }
  for (std::size_t t = 0; t < rows; ++t) {
    scale_[t] = calibration_->innovation_scale(used_[t], level_[t]);
  }
  bank_->candidate_log_likelihoods(plots, gate, std::span<const double>(scale_.data(), rows), out);
}

void CalibratedTrackBank::candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots,
                                                    double gate, std::span<const double> gate_scale,
                                                    Eigen::Ref<Eigen::MatrixXd> out) {
  bank::check_gate_scale(gate_scale, out.rows());
  if (gate_scale.size() > used_.size()) {  // the wrapped bank names the sizes
    bank_->candidate_log_likelihoods(plots, gate, gate_scale, out);
    return;
  }
  for (std::size_t t = 0; t < gate_scale.size(); ++t) {
    scale_[t] = gate_scale[t] * calibration_->innovation_scale(used_[t], level_[t]);
  }
  bank_->candidate_log_likelihoods(plots, gate,
                                   std::span<const double>(scale_.data(), gate_scale.size()), out);
}

long CalibratedTrackBank::plots_used(std::size_t track) const { return used_[checked(track)]; }

double CalibratedTrackBank::nis_level(std::size_t track) const { return level_[checked(track)]; }

double CalibratedTrackBank::innovation_scale(std::size_t track) const {
  const std::size_t t = checked(track);
  return calibration_->innovation_scale(used_[t], level_[t]);
}

double CalibratedTrackBank::state_scale(std::size_t track) const {
  const std::size_t t = checked(track);
  return calibration_->state_scale(used_[t], level_[t]);
}

}  // namespace imm
