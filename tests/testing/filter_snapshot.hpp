// SPDX-License-Identifier: Apache-2.0
#pragma once
/// A TrackFilter's estimate as bits (to compare two filters driven two ways to the bit) and a
/// common start of two filters near a first plot.

#include <Eigen/Core>
#include <cmath>
#include <cstring>

#include "imm/tracking/track_filter.hpp"
#include "imm/tracking/track_options.hpp"

namespace imm::testing {

struct Snapshot {
  Eigen::VectorXd mean, variance;
  Eigen::MatrixXd covariance;
  explicit Snapshot(const TrackFilter& f)
      : mean(f.state_dimension()),
        variance(f.state_dimension()),
        covariance(f.state_dimension(), f.state_dimension()) {
    f.state(mean, variance);
    f.covariance(covariance);
  }
  bool operator==(const Snapshot& o) const {
    return std::memcmp(mean.data(), o.mean.data(), sizeof(double) * mean.size()) == 0 &&
           std::memcmp(covariance.data(), o.covariance.data(),
                       sizeof(double) * covariance.size()) == 0;
  }
};

/// A start at the first plot's position with a broad covariance.
inline void start_both(TrackFilter& a, TrackFilter& b, const TrackOptions& options,
                       const Eigen::Vector2d& first) {
  const int n = a.state_dimension();
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(n);
  const int y = n >= 6 ? 3 : 2;
  if (options.measurement_kind == MeasurementKind::kPolar) {
    mean(0) = first(0) * std::cos(first(1));
    mean(y) = first(0) * std::sin(first(1));
  } else {
    mean(0) = first(0);
    mean(y) = first(1);
  }
  const double r = options.measurement_kind == MeasurementKind::kPolar
                       ? first(0) * first(0) * options.measurement_covariance(1, 1)
                       : options.measurement_covariance(0, 0);
  Eigen::MatrixXd P = Eigen::MatrixXd::Identity(n, n) * 100.0 * r;
  if (n % 2 == 1) P(n - 1, n - 1) = 1e-4;  // the turn rate
  a.initialize(mean, P);
  b.initialize(mean, P);
}

}  // namespace imm::testing
