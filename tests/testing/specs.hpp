// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Filter specs shared by several tests.

#include "imm/filters/plain_imm.hpp"

namespace imm::testing {

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
