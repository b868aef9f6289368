// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Filter specs shared by several tests.

#include <string>
#include <utility>
#include <vector>

#include "imm/filters/plain_imm.hpp"

namespace imm::testing {

/// A plain-IMM mode: q its process noise, q_omega the turn rate's (CT modes).
inline ModeSpec mode_spec(std::string name, MotionKind motion, double q, double q_omega = 0.0) {
  ModeSpec m;
  m.name = std::move(name);
  m.motion = motion;
  m.process_noise = q;
  m.turn_noise = q_omega;
  return m;
}

/// A plain IMM of `modes` over period T that leaves each mode with probability `leave` per period
/// (spread evenly over the others; a single mode stays), starts with equal probabilities, takes
/// plots of `kind` with covariance R, and starts tracks with the priors 4 (length/s²)² on the
/// acceleration and 0.01 rad²/s² on the turn rate.
inline PlainImmSpec switching_spec(std::vector<ModeSpec> modes, double T, double leave,
                                   MeasurementKind kind, const Eigen::Matrix2d& R) {
  PlainImmSpec spec;
  spec.sample_period = T;
  const auto n = static_cast<Eigen::Index>(modes.size());
  spec.modes = std::move(modes);
  spec.transition =
      Eigen::MatrixXd::Constant(n, n, n == 1 ? 1.0 : leave / static_cast<double>(n - 1));
  spec.transition.diagonal().setConstant(n == 1 ? 1.0 : 1.0 - leave);
  spec.initial_probabilities = Eigen::VectorXd::Constant(n, 1.0 / static_cast<double>(n));
  spec.measurement.kind = kind;
  spec.measurement.covariance = R;
  spec.initialization.turn_rate_variance = 0.01;
  spec.initialization.acceleration_variance = 4.0;
  return spec;
}

/// The three-level CV IMM of configs/track/cv3_imm.toml, built in code.
inline PlainImmSpec cv3_spec() {
  PlainImmSpec spec;
  spec.sample_period = 1.0;
  spec.modes = {{"quiet", MotionKind::kConstantVelocity, 1e-6},
                {"moderate", MotionKind::kConstantVelocity, 1e-4},
                {"agile", MotionKind::kConstantVelocity, 1e-2}};
  spec.transition = Eigen::Matrix3d::Constant(0.015);
  spec.transition.diagonal().setConstant(0.97);
  spec.initial_probabilities = Eigen::Vector3d(0.6, 0.2, 0.2);
  spec.measurement.covariance = 0.25 * Eigen::Matrix2d::Identity();
  return spec;
}

}  // namespace imm::testing
