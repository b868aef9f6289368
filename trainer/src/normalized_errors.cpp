// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/normalized_errors.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace imm::trainer {
namespace {

Eigen::VectorXd ratio(const Eigen::VectorXd& error, const Eigen::VectorXd& reference,
                      const Eigen::VectorXi& samples) {
  Eigen::VectorXd result(error.size());
  for (Eigen::Index k = 0; k < error.size(); ++k) {
    result(k) = (samples(k) > 0 && reference(k) > 0.0)
                    ? std::sqrt(error(k)) / std::sqrt(reference(k))
                    : std::numeric_limits<double>::quiet_NaN();
  }
  return result;
}

}  // namespace

NormalizedErrors::NormalizedErrors(int steps)
    : position_error_(Eigen::VectorXd::Zero(steps)),
      position_measurement_(Eigen::VectorXd::Zero(steps)),
      velocity_error_(Eigen::VectorXd::Zero(steps)),
      velocity_measurement_(Eigen::VectorXd::Zero(steps)),
      samples_(Eigen::VectorXi::Zero(steps)) {
  if (steps < 1) throw std::invalid_argument("NormalizedErrors needs at least one scan");
}

void NormalizedErrors::add(int k, const Eigen::Vector2d& true_position,
                           const Eigen::Vector2d& estimated_position,
                           const Eigen::Vector2d& measured_position,
                           const Eigen::Vector2d& true_velocity,
                           const Eigen::Vector2d& estimated_velocity,
                           const Eigen::Vector2d& measured_velocity) {
  if (k < 0 || k >= samples_.size()) throw std::out_of_range("scan outside the evaluation");
  position_error_(k) += (true_position - estimated_position).squaredNorm();
  position_measurement_(k) += (true_position - measured_position).squaredNorm();
  velocity_error_(k) += (true_velocity - estimated_velocity).squaredNorm();
  velocity_measurement_(k) += (true_velocity - measured_velocity).squaredNorm();
  ++samples_(k);
}

Eigen::VectorXd NormalizedErrors::position() const {
  return ratio(position_error_, position_measurement_, samples_);
}

Eigen::VectorXd NormalizedErrors::velocity() const {
  return ratio(velocity_error_, velocity_measurement_, samples_);
}

double NormalizedErrors::zeta_p() const {
  return mean_normalized_ratio(position_error_, position_measurement_, samples_,
                               position_error_.size());
}
double NormalizedErrors::zeta_v() const {
  return mean_normalized_ratio(velocity_error_, velocity_measurement_, samples_,
                               velocity_error_.size());
}

double NormalizedErrors::position_rmse() const {
  return std::sqrt(position_error_.sum() / std::max(1, samples_.sum()));
}

double NormalizedErrors::velocity_rmse() const {
  return std::sqrt(velocity_error_.sum() / std::max(1, samples_.sum()));
}

StepConsistency step_consistency(const TrackFilter& filter, const Eigen::Vector2d& position) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  StepConsistency out{kNaN, kNaN};
  const int n = filter.state_dimension();
  const int y = n / 2;
  Eigen::VectorXd mean(n), variance(n);
  Eigen::MatrixXd covariance(n, n);
  filter.state(mean, variance);
  filter.covariance(covariance);
  Eigen::Matrix2d block;
  block << covariance(0, 0), covariance(0, y), covariance(y, 0), covariance(y, y);
  const Eigen::Vector2d e = position - Eigen::Vector2d(mean(0), mean(y));
  const Eigen::LLT<Eigen::Matrix2d> position_llt(block);
  if (position_llt.info() == Eigen::Success) out.position_nees = e.dot(position_llt.solve(e));
  out.nis = last_step_nis(filter).value_or(kNaN);
  return out;
}

}  // namespace imm::trainer
