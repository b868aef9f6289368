// SPDX-License-Identifier: Apache-2.0
// A tracking application as users write it: links imm::runtime only, builds a filter in code.
#include <cstdio>
#include <imm/filters/plain_imm.hpp>

int main() {
  imm::PlainImmSpec spec;
  spec.sample_period = 1.0;  // the sensor's scan period, s
  spec.modes = {{"quiet", imm::MotionKind::kConstantVelocity, 1e-6},
                {"agile", imm::MotionKind::kConstantVelocity, 1e-2}};
  spec.transition = Eigen::Matrix2d{{0.97, 0.03}, {0.03, 0.97}};
  spec.initial_probabilities = Eigen::Vector2d(0.5, 0.5);
  spec.measurement.covariance = 0.25 * Eigen::Matrix2d::Identity();
  auto imm = imm::build_plain_imm<4>(spec);
  imm.initialize(imm::GaussianState<4>{});
  for (int k = 1; k <= 20; ++k) {
    if (imm.step(imm::Vector<2>(0.1 * k, 0.2 * k)) != imm::StepStatus::kOk) return 1;
  }
  std::printf("consumer: x = %.3f, y = %.3f\n", imm.estimate().mean(0), imm.estimate().mean(2));
  return imm.estimate().all_finite() ? 0 : 1;
}
