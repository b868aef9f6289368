// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/normalized_errors.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "imm/filters/axis_cv_imm.hpp"

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

namespace imm::trainer {
namespace {

// One step of a one-level CV IMM per axis (a Kalman filter, Q = q G Gᵀ with G = [T²/2, T]),
// worked by hand: T = 1, R = 0.25, q = 0.01, started at [1, 0.5] and [2, −0.3] with covariance
// [[R, R/T], [R/T, 2R/T²]], plot (1.7, 1.6). Per axis P⁻ = F P Fᵀ + q G Gᵀ has P⁻₀₀ = 1.25 +
// 0.0025, so S = 1.5025; the predictions are 1.5 and 1.7, the innovations 0.2 and −0.1.
TEST(StepConsistency, IsTheHandComputedNeesAndNisOfAKalmanStep) {
  AxisCvImmSpec spec;
  spec.settings.sample_period = 1.0;
  spec.settings.sample_period = 1.0;
  spec.settings.measurement_sigma = 0.5;
  spec.process_noise = {0.01};
  const std::unique_ptr<TwoAxisFilter> filter = make_axis_cv_imm_filter(spec);
  const double r = 0.25;
  Eigen::VectorXd mean(4);
  mean << 1.0, 0.5, 2.0, -0.3;
  Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(4, 4);
  for (int a = 0; a < 2; ++a) covariance.block<2, 2>(2 * a, 2 * a) << r, r, r, 2.0 * r;
  filter->initialize(mean, covariance);
  const Eigen::Vector2d truth(1.6, 1.65);
  EXPECT_TRUE(std::isnan(step_consistency(*filter, truth).nis));  // no update yet
  ASSERT_EQ(filter->step(Eigen::Vector2d(1.7, 1.6)), StepStatus::kOk);
  const StepConsistency c = step_consistency(*filter, truth);

  const double predicted_variance = 1.25 + 0.01 * 0.25, S = predicted_variance + r;
  EXPECT_NEAR(c.nis, (0.2 * 0.2 + 0.1 * 0.1) / S, 1e-12);
  const double gain = predicted_variance / S;
  const double posterior_variance = (1.0 - gain) * predicted_variance;
  const double x = 1.5 + gain * 0.2, y = 1.7 + gain * -0.1;
  EXPECT_NEAR(c.position_nees, (std::pow(1.6 - x, 2) + std::pow(1.65 - y, 2)) / posterior_variance,
              1e-10);
  ASSERT_EQ(filter->predict_only(), StepStatus::kOk);
  EXPECT_TRUE(std::isnan(step_consistency(*filter, truth).nis));  // no plot in this cycle
}

}  // namespace
}  // namespace imm::trainer
