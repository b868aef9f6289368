// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/normalized_errors.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace imm::trainer {
namespace {

// Two runs, scan 1, by hand:
//   run 1: ‖p − p̂‖² = 3² + 4² = 25, ‖p − z‖² = 6² + 8² = 100
//   run 2: ‖p − p̂‖² = 0,            ‖p − z‖² = 0² + 10² = 100
//   P_e(1) = √25 / √200 = 5 / 14.142… = 0.35355
TEST(NormalizedErrors, HandComputedExample) {
  NormalizedErrors errors(3);
  const Eigen::Vector2d zero = Eigen::Vector2d::Zero();
  errors.add(1, zero, Eigen::Vector2d(3, 4), Eigen::Vector2d(6, 8), zero, Eigen::Vector2d(1, 0),
             Eigen::Vector2d(2, 0));
  errors.add(1, zero, zero, Eigen::Vector2d(0, 10), zero, Eigen::Vector2d(0, 1),
             Eigen::Vector2d(0, 2));
  errors.add(2, zero, Eigen::Vector2d(1, 0), Eigen::Vector2d(2, 0), zero, zero,
             Eigen::Vector2d(1, 1));
  const Eigen::VectorXd pe = errors.position();
  EXPECT_TRUE(std::isnan(pe(0)));  // no samples at scan 0
  EXPECT_NEAR(pe(1), 5.0 / std::sqrt(200.0), 1e-15);
  EXPECT_NEAR(pe(2), 0.5, 1e-15);
  EXPECT_NEAR(errors.zeta_p(), (5.0 / std::sqrt(200.0) + 0.5) / 2.0, 1e-15);
  // V_e(1) = √2 / √8 = 0.5; V_e(2) = 0 / √2 = 0
  EXPECT_NEAR(errors.velocity()(1), 0.5, 1e-15);
  EXPECT_NEAR(errors.velocity()(2), 0.0, 1e-15);
  EXPECT_NEAR(errors.zeta_v(), 0.25, 1e-15);
  EXPECT_NEAR(errors.position_rmse(), std::sqrt(26.0 / 3.0), 1e-15);
  EXPECT_THROW(errors.add(3, zero, zero, zero, zero, zero, zero), std::out_of_range);
}

}  // namespace
}  // namespace imm::trainer
