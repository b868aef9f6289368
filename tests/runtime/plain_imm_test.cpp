// SPDX-License-Identifier: Apache-2.0
#include "imm/filters/plain_imm.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <typeinfo>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/estimation/kalman_mode.hpp"
#include "imm/filters/axis_filter.hpp"
#include "imm/filters/fcm_imm.hpp"
#include "imm/filters/fimm.hpp"
#include "imm/filters/mlp_input_estimator.hpp"
#include "imm/filters/wimm.hpp"
#include "imm/models/measurement/position_measurement.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/tracking/tracker.hpp"
#include "testing/matrix_checks.hpp"
#include "testing/refused_field.hpp"
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

// The IMM of a CV spec with Cartesian plots, assembled from the general Kalman mode
// (kalman_filter.hpp's Eigen algebra): the reference for build_plain_imm's written-out mode.
ImmEstimator<4, 2> general_cv_imm(const PlainImmSpec& spec) {
  using Mode = KalmanMode<4, 4, PositionMeasurement<4, 2>>;
  std::vector<std::unique_ptr<ImmMode<4, 2>>> modes;
  for (const ModeSpec& mode : spec.modes) {
    modes.push_back(std::make_unique<Mode>(
        mode.name, constant_velocity<2>(spec.sample_period, mode.process_noise, mode.noise_form),
        PositionMeasurement<4, 2>({0, 2}, spec.measurement.covariance), StateEmbedding<4, 4>()));
  }
  return {std::move(modes), spec.transition, spec.initial_probabilities};
}

// 1e-8 relative: 150 scans with 1e6-σ outliers accumulate the two algebras' rounding (and an
// unoptimized build sums Eigen's products in yet another order).
void expect_close(double value, double reference, const std::string& what) {
  EXPECT_LE(std::abs(value - reference), 1e-8 * (1.0 + std::abs(reference))) << what;
}

// build_plain_imm runs CV modes with Cartesian plots through cv_position_algebra.hpp (the
// TrackBank's per-track arithmetic). Against the general mode, over random specs and plots with
// NaN plots, 1e6-σ outliers and a prior that makes S singular, every status, estimate, log μ and
// innovation agrees to rounding.
TEST(PlainImm, TheWrittenOutCvModeIsTheGeneralKalmanModeToRounding) {
  std::mt19937_64 rng(20261126);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int compared_steps = 0, failed_steps = 0;
  for (int trial = 0; trial < 12; ++trial) {
    auto spec = testing::cv3_spec();
    spec.sample_period = 0.1 + 4.0 * unit(rng);
    for (auto& mode : spec.modes) {
      mode.process_noise = std::pow(10.0, -6.0 + 5.0 * unit(rng));
      mode.noise_form = trial % 2 == 0 ? NoiseForm::kPiecewiseConstant : NoiseForm::kContinuous;
    }
    const double sx = 0.1 + unit(rng), sy = 0.1 + unit(rng), rho = -0.8 + 1.6 * unit(rng);
    spec.measurement.covariance << sx * sx, rho * sx * sy, rho * sx * sy, sy * sy;
    auto fast = build_plain_imm<4>(spec);
    const auto& first_mode = fast.mode(0);
    ASSERT_NE(std::string(typeid(first_mode).name()).find("CvPositionMode"), std::string::npos);
    auto general = general_cv_imm(spec);
    GaussianState<4> start;
    start.mean << 10.0 * unit(rng), unit(rng), -5.0 * unit(rng), unit(rng);
    start.covariance = Eigen::Vector4d(4.0, 1.0, 4.0, 1.0).asDiagonal();
    if (trial == 11) start.covariance(0, 0) = -1e3;  // S₀₀ < 0 at every scan: never updates
    fast.initialize(start);
    general.initialize(start);
    Eigen::Vector4d truth = start.mean;
    std::normal_distribution<double> noise(0.0, 1.0);
    for (int k = 0; k < 150; ++k) {
      truth(0) += spec.sample_period * truth(1);
      truth(2) += spec.sample_period * truth(3);
      truth(1) += 0.2 * noise(rng);
      truth(3) += 0.2 * noise(rng);
      Vector<2> z(truth(0) + sx * noise(rng), truth(2) + sy * noise(rng));
      if (k % 37 == 5) z(1) = std::numeric_limits<double>::quiet_NaN();
      if (k % 41 == 7) z(0) += 1e6 * sx;
      const StepStatus status = fast.step(z);
      ASSERT_EQ(status, general.step(z)) << "trial " << trial << " scan " << k;
      if (status != StepStatus::kOk) ++failed_steps;
      const std::string at = "trial " + std::to_string(trial) + " scan " + std::to_string(k);
      for (int a = 0; a < 4; ++a) {
        expect_close(fast.estimate().mean(a), general.estimate().mean(a), at + " mean");
        for (int c = 0; c < 4; ++c) {
          expect_close(fast.estimate().covariance(a, c), general.estimate().covariance(a, c),
                       at + " covariance");
        }
      }
      // μ to 1e-8; log μ to 1e-7 relative: after a 1e6-σ outlier the log-likelihoods are near
      // −1e11, and their rounding reaches log μ through the normalization.
      for (int j = 0; j < 3; ++j) {
        expect_close(fast.mode_probabilities()(j), general.mode_probabilities()(j), at + " mu");
        const double reference = general.log_mode_probabilities()(j);
        EXPECT_LE(std::abs(fast.log_mode_probabilities()(j) - reference),
                  1e-7 * (1.0 + std::abs(reference)))
            << at << " log mu";
      }
      Vector<2> nu_fast, nu_general;
      SquareMatrix<2> s_fast, s_general;
      const bool updated = fast.innovation(nu_fast, s_fast);
      ASSERT_EQ(updated, general.innovation(nu_general, s_general));
      for (int a = 0; a < 2 && updated; ++a) {
        expect_close(nu_fast(a), nu_general(a), at + " innovation");
        for (int c = 0; c < 2; ++c) expect_close(s_fast(a, c), s_general(a, c), at + " S");
      }
      ++compared_steps;
      if (::testing::Test::HasFailure()) return;
    }
  }
  EXPECT_EQ(compared_steps, 12 * 150);
  EXPECT_GT(failed_steps, 150);  // the singular trial's 150 scans, and the NaN plots
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
  // A name a file or config holds is quoted on one line, its bytes outside printable ASCII
  // escaped, whatever it holds (a fuzzed model file's noise form had a line break).
  try {
    (void)noise_form_from("piecewise\nconstant\x01", "modes[2].noise_form");
    FAIL() << "accepted";
  } catch (const InvalidParameter& error) {
    EXPECT_EQ(error.field(), "modes[2].noise_form");
    EXPECT_NE(std::string(error.what()).find("unknown noise form 'piecewise\\x0aconstant\\x01'"),
              std::string::npos)
        << error.what();
  }
  EXPECT_EQ(printable(std::string(100, 'a')), std::string(64, 'a'));
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

// Scans up to 2⁶⁴ − 1 apart (a recording whose scans start near −2⁶³): every gap is counted
// exactly, never wrapped into a negative one. A plot more than max_gap scans after the first is a
// new first plot; one that far after a running track starts it again; the start's velocity is
// that of the true span.
TEST(PlainImmTracker, ScansFurtherApartThanASignedDifferenceReachesAreCountedExactly) {
  constexpr std::int64_t kFirst = std::numeric_limits<std::int64_t>::min();
  constexpr std::int64_t kLast = std::numeric_limits<std::int64_t>::max();
  auto spec = cv3_spec();
  spec.sample_period = 0.5;
  PlainImmTracker tracker(spec);
  EXPECT_EQ(tracker.process(kFirst, Eigen::Vector2d(0.0, 0.0)).event, TrackEvent::kWaiting);
  EXPECT_EQ(tracker.process(kLast - 3, Eigen::Vector2d(2.0, -1.0)).event, TrackEvent::kWaiting);
  EXPECT_EQ(tracker.process(kLast - 2, Eigen::Vector2d(3.0, -1.5)).event, TrackEvent::kInitialized);
  Eigen::VectorXd mean(4), variance(4);
  tracker.state(mean, variance);
  EXPECT_TRUE(testing::matrices_near(mean, Eigen::Vector4d(3.0, 2.0, -1.5, -1.0), 1e-15));
  PlainImmTracker running(spec);
  (void)running.process(kFirst, Eigen::Vector2d(0.0, 0.0));
  ASSERT_EQ(running.process(kFirst + 1, Eigen::Vector2d(1.0, 0.0)).event, TrackEvent::kInitialized);
  EXPECT_EQ(running.process(kLast, Eigen::Vector2d(5.0, 5.0)).event, TrackEvent::kWaiting);
  EXPECT_FALSE(running.initialized());
  const std::optional<TrackStart> start =
      two_point_start(spec.track_options(50), 4, kFirst, Eigen::Vector2d(0.0, 0.0), kLast,
                      Eigen::Vector2d(1e3, -1e3));
  ASSERT_TRUE(start.has_value());
  EXPECT_GT(start->mean(1), 0.0);  // 1e3 over 2⁶⁴ − 1 scans: positive, about 1e-16
  EXPECT_LT(start->mean(1), 1e-15);
  EXPECT_LT(start->mean(3), 0.0);
}

// A gap is predicted through scan by scan, so max_gap is bounded (a million scans): a plot 10¹⁵
// scans on with the largest max_gap restarts the track at once instead of predicting for days.
TEST(PlainImmTracker, MaxGapIsBoundedSoThatNoPlotCostsMoreThanAMillionPredictions) {
  const auto spec = cv3_spec();
  for (const std::int64_t bad : {std::int64_t{0}, std::int64_t{1'000'001}}) {
    EXPECT_EQ(testing::refused_field_of([&] { PlainImmTracker refused(spec, bad); }), "max_gap")
        << bad;
  }
  PlainImmTracker tracker(spec, 1'000'000);
  (void)tracker.process(0, Eigen::Vector2d(0.0, 0.0));
  ASSERT_EQ(tracker.process(1, Eigen::Vector2d(1.0, 0.0)).event, TrackEvent::kInitialized);
  EXPECT_EQ(tracker.process(1'000'000'000'000'000, Eigen::Vector2d(2.0, 0.0)).event,
            TrackEvent::kWaiting);
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

// A spec built in code gets its sample period from its regime or model file, never from a default:
// left unset, every kind's spec is refused naming the field, and so is a tracker's.
TEST(SamplePeriod, AnUnsetPeriodIsRefusedByNameInEverySpec) {
  const auto refusal = [](auto&& call) -> std::string {
    try {
      call();
    } catch (const InvalidParameter& error) {
      return error.field() + ": " + error.what();
    }
    return "accepted";
  };
  const auto expect_unset = [&](auto&& call) {
    const std::string text = refusal(call);
    EXPECT_EQ(text.rfind("sample_period: ", 0), 0U) << text;
    EXPECT_NE(text.find("not set"), std::string::npos) << text;
  };
  PlainImmSpec plain = testing::cv3_spec();
  plain.sample_period = 0.0;
  expect_unset([&] { plain.validate(); });
  expect_unset([] { AxisImmSettings{}.validate(); });
  expect_unset([] { CvKfSettings{}.validate(); });
  expect_unset([] { FcmImmSpec{}.validate(); });
  expect_unset([] { FimmSpec{}.validate(); });
  expect_unset([] { WimmSpec{}.validate(); });
  TrackOptions options = testing::cv3_spec().track_options();
  options.sample_period = 0.0;
  expect_unset([&] { Tracker(make_plain_imm_filter(testing::cv3_spec()), options); });
}

}  // namespace
}  // namespace imm
