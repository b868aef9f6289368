// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The normalized errors of seed 000 §4, accumulated over Monte Carlo runs (and, per step, the
/// consistency statistics NEES and NIS):
///   P_e(k) = √(Σ_s ‖p − p̂‖²) / √(Σ_s ‖p − z‖²),  V_e(k) = √(Σ_s ‖v − v̂‖²) / √(Σ_s ‖v − v̄‖²),
/// with v̄(k) = (z(k) − z(k−1))/T the "measured velocity", and ζ_p, ζ_v their means over the
/// scans. Values below 1 mean the filter beats the raw measurements. RMSEs come with them.

#include <Eigen/Core>
#include <cmath>
#include <limits>

#include "imm/tracking/track_filter.hpp"

namespace imm::trainer {

/// The position NEES (x − x̂)ᵀ P⁻¹ (x − x̂) of a filter's combined estimate over its position block
/// (state entries 0 and n/2) against the true `position`, and the NIS νᵀ S⁻¹ ν of its last cycle
/// (TrackFilter::innovation): NaN where the covariance is not positive definite, or, for the NIS,
/// where the last call was not a successful update.
struct StepConsistency {
  double position_nees = 0.0;
  double nis = 0.0;
};
[[nodiscard]] StepConsistency step_consistency(const TrackFilter& filter,
                                               const Eigen::Vector2d& position);

/// ζ from per-scan sums (NormalizedErrors::zeta_p and zeta_v, and the GA's fitness batch): the
/// mean, over the scans k < n with samples(k) > 0 and reference(k) > 0 whose ratio is finite, of
/// √error(k) / √reference(k); NaN when no scan qualifies. Any indexable containers.
template <class Error, class Reference, class Samples>
[[nodiscard]] double mean_normalized_ratio(const Error& error, const Reference& reference,
                                           const Samples& samples, long n) {
  double sum = 0.0;
  int count = 0;
  for (long k = 0; k < n; ++k) {
    if (!(samples[k] > 0) || !(reference[k] > 0.0)) continue;
    const double ratio = std::sqrt(error[k]) / std::sqrt(reference[k]);
    if (!std::isfinite(ratio)) continue;
    sum += ratio;
    ++count;
  }
  return count > 0 ? sum / count : std::numeric_limits<double>::quiet_NaN();
}

class NormalizedErrors {
 public:
  explicit NormalizedErrors(int steps);

  /// Adds one run's scan k.
  void add(int k, const Eigen::Vector2d& true_position, const Eigen::Vector2d& estimated_position,
           const Eigen::Vector2d& measured_position, const Eigen::Vector2d& true_velocity,
           const Eigen::Vector2d& estimated_velocity, const Eigen::Vector2d& measured_velocity);

  /// P_e(k) and V_e(k); NaN at scans without samples.
  [[nodiscard]] Eigen::VectorXd position() const;
  [[nodiscard]] Eigen::VectorXd velocity() const;
  /// Means over the scans with samples (seed 000's ζ_p, ζ_v).
  [[nodiscard]] double zeta_p() const;
  [[nodiscard]] double zeta_v() const;
  /// Root mean square errors over every sample.
  [[nodiscard]] double position_rmse() const;
  [[nodiscard]] double velocity_rmse() const;

 private:
  Eigen::VectorXd position_error_;        // Σ_s ‖p − p̂‖² per scan
  Eigen::VectorXd position_measurement_;  // Σ_s ‖p − z‖²
  Eigen::VectorXd velocity_error_;
  Eigen::VectorXd velocity_measurement_;
  Eigen::VectorXi samples_;
};

}  // namespace imm::trainer
