// SPDX-License-Identifier: Apache-2.0
#include "imm/filters/plain_imm.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "imm/core/invalid_parameter.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/tracking/tracker.hpp"
#include "testing/matrix_checks.hpp"
#include "testing/specs.hpp"

namespace imm {
namespace {

using testing::cv3_spec;

std::string invalid_field(const PlainImmSpec& spec) {
  try {
    spec.validate();
  } catch (const InvalidParameter& error) {
    return error.field();
  }
  return "";
}

TEST(PlainImmSpec, ValidationNamesTheField) {
  EXPECT_EQ(invalid_field(cv3_spec()), "");
  auto spec = cv3_spec();
  spec.modes[1].process_noise = -1.0;
  EXPECT_EQ(invalid_field(spec), "modes[1].process_noise");
  spec = cv3_spec();
  spec.modes[2].name = "quiet";
  EXPECT_EQ(invalid_field(spec), "modes[2].name");
  spec = cv3_spec();
  spec.sample_period = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(invalid_field(spec), "sample_period");
  spec = cv3_spec();
  spec.transition(0, 0) = 0.5;
  EXPECT_EQ(invalid_field(spec), "transition");
  spec = cv3_spec();
  spec.initial_probabilities(0) = 0.9;
  EXPECT_EQ(invalid_field(spec), "initial_probabilities");
  spec = cv3_spec();
  spec.measurement.covariance(0, 1) = 1.0;
  EXPECT_EQ(invalid_field(spec), "measurement.covariance");
  spec = cv3_spec();
  spec.modes[0].motion = MotionKind::kSinger;
  spec.modes[0].singer_tau = 0.0;
  EXPECT_EQ(invalid_field(spec), "modes[0].tau");
  spec = cv3_spec();
  spec.initialization.method = InitializationMethod::kExplicit;
  spec.initialization.state = Eigen::VectorXd::Zero(3);
  EXPECT_EQ(invalid_field(spec), "initialization.state");
}

TEST(PlainImmSpec, MixingDimensionFollowsTheModes) {
  auto spec = cv3_spec();
  EXPECT_EQ(spec.mixing_dimension(), 4);
  EXPECT_EQ(build_plain_imm(spec).index(), 0u);
  spec.modes[2].motion = MotionKind::kSinger;
  spec.modes[2].singer_sigma = 0.05;
  EXPECT_EQ(spec.mixing_dimension(), 6);
  EXPECT_EQ(build_plain_imm(spec).index(), 1u);
  EXPECT_THROW((void)build_plain_imm<4>(spec), InvalidParameter);
}

TEST(PlainImmSpec, NamesRoundTrip) {
  for (auto kind :
       {MotionKind::kConstantVelocity, MotionKind::kConstantAcceleration, MotionKind::kSinger}) {
    EXPECT_EQ(motion_kind_from(to_string(kind), "f"), kind);
  }
  EXPECT_THROW((void)motion_kind_from("turn", "modes[0].motion"), InvalidParameter);
  EXPECT_EQ(noise_form_from("continuous", "f"), NoiseForm::kContinuous);
  EXPECT_EQ(measurement_kind_from("polar", "f"), MeasurementKind::kPolar);
  EXPECT_EQ(initialization_method_from("two_point", "f"), InitializationMethod::kTwoPoint);
}

// Two-point initialization by hand: plots (0, 0) at scan 3 and (2, −1) at scan 5, T = 0.5:
// x = [2, 2/(2·0.5), −1, −1/1] = [2, 2, −1, −1]; var(x) = r, var(vx) = 2r/Δt², cov = r/Δt.
TEST(PlainImmTracker, TwoPointInitializationByHand) {
  auto spec = cv3_spec();
  spec.sample_period = 0.5;
  PlainImmTracker tracker(spec);
  EXPECT_EQ(tracker.process(3, Eigen::Vector2d(0.0, 0.0)).event, TrackEvent::kWaiting);
  EXPECT_FALSE(tracker.initialized());
  EXPECT_EQ(tracker.process(5, Eigen::Vector2d(2.0, -1.0)).event, TrackEvent::kInitialized);
  Eigen::VectorXd mean(4), variance(4);
  tracker.state(mean, variance);
  EXPECT_TRUE(testing::matrices_near(mean, Eigen::Vector4d(2.0, 2.0, -1.0, -1.0), 1e-15));
  EXPECT_TRUE(testing::matrices_near(variance, Eigen::Vector4d(0.25, 0.5, 0.25, 0.5), 1e-15));
}

TEST(PlainImmTracker, BadPlotsAreRejectedAndGapsPredicted) {
  PlainImmTracker tracker(cv3_spec());
  ASSERT_EQ(tracker.process(0, Eigen::Vector2d(0.0, 0.0)).event, TrackEvent::kWaiting);
  ASSERT_EQ(tracker.process(1, Eigen::Vector2d(1.0, 0.5)).event, TrackEvent::kInitialized);
  ASSERT_EQ(tracker.process(2, Eigen::Vector2d(2.0, 1.0)).event, TrackEvent::kUpdated);
  Eigen::VectorXd mean(4), variance(4), mean_after(4), variance_after(4);
  tracker.state(mean, variance);
  const ModeVector mu = tracker.mode_probabilities();

  for (const auto& [scan, z] :
       {std::pair{3L, Eigen::Vector2d(std::nan(""), 0.0)},
        std::pair{3L, Eigen::Vector2d(0.0, std::numeric_limits<double>::infinity())},
        std::pair{2L, Eigen::Vector2d(2.0, 1.0)},     // repeated scan
        std::pair{1L, Eigen::Vector2d(1.0, 0.5)}}) {  // decreasing scan
    const TrackStepResult result = tracker.process(scan, z);
    EXPECT_EQ(result.event, TrackEvent::kRejected);
    EXPECT_FALSE(result.reason.empty());
    tracker.state(mean_after, variance_after);
    EXPECT_EQ(mean_after, mean);
    EXPECT_EQ(variance_after, variance);
    EXPECT_EQ(tracker.mode_probabilities(), mu);
  }
  // Scans 3 and 4 had no usable plot: predicted through before updating at 5.
  const TrackStepResult result = tracker.process(5, Eigen::Vector2d(5.0, 2.5));
  EXPECT_EQ(result.event, TrackEvent::kUpdated);
  EXPECT_EQ(result.predicted_scans, 2);
  tracker.state(mean_after, variance_after);
  EXPECT_NEAR(mean_after(0), 5.0, 0.2);
}

TEST(PlainImmTracker, ExplicitInitializationUsesTheGivenPrior) {
  auto spec = cv3_spec();
  spec.initialization.method = InitializationMethod::kExplicit;
  spec.initialization.state = Eigen::Vector4d(0.0, 1.0, 0.0, 0.0);
  spec.initialization.covariance = Eigen::Vector4d(1.0, 0.1, 1.0, 0.1).asDiagonal();
  PlainImmTracker tracker(spec);
  EXPECT_EQ(tracker.process(0, Eigen::Vector2d(1.0, 0.0)).event, TrackEvent::kInitialized);
  // Every mode: one KF step from the prior; the first mode alone gives the same mean here because
  // the prediction is the same for all modes and only Q differs slightly.
  Eigen::VectorXd mean(4), variance(4);
  tracker.state(mean, variance);
  EXPECT_NEAR(mean(0), 1.0, 1e-3);
  EXPECT_NEAR(mean(1), 1.0, 1e-3);
}

}  // namespace
}  // namespace imm
