// SPDX-License-Identifier: Apache-2.0
// The envelope test of a tracker (imm/tracking/envelope.hpp): its bounds against χ² tables, a
// window computed by hand, its false-alarm rate on a filter that matches its plots exactly, and
// how soon it flags plots of a target manoeuvring harder than the model knows.

#include "imm/tracking/envelope.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <random>

#include "imm/core/invalid_parameter.hpp"
#include "imm/tracking/tracker.hpp"

namespace imm {
namespace {

TEST(Envelope, BoundsAreTheChiSquareQuantilesOfTheWindow) {
  // 10 plots of 2 dimensions: χ² with 20 degrees of freedom; 1 % two-sided (tables: 7.434, 39.997).
  const EnvelopeMonitor monitor({10, 0.01});
  EXPECT_NEAR(monitor.lower_sum(), 7.4338, 1e-3);
  EXPECT_NEAR(monitor.upper_sum(), 39.9968, 1e-3);
  // 20 plots at 5 %: χ²₄₀(0.025) = 24.433, χ²₄₀(0.975) = 59.342.
  const EnvelopeMonitor wider({20, 0.05});
  EXPECT_NEAR(wider.lower_sum(), 24.4330, 1e-3);
  EXPECT_NEAR(wider.upper_sum(), 59.3417, 1e-3);
}

TEST(Envelope, AWindowComputedByHand) {
  EnvelopeMonitor monitor({10, 0.01});
  EXPECT_TRUE(std::isnan(monitor.mean()));
  for (int i = 0; i < 9; ++i) EXPECT_FALSE(monitor.add(0.0)) << "not full: never outside";
  for (int i = 0; i < 10; ++i) monitor.add(2.0);  // sum 20: inside [7.43, 40.00]
  EXPECT_FALSE(monitor.outside());
  EXPECT_DOUBLE_EQ(monitor.mean(), 2.0);
  EXPECT_FALSE(monitor.add(10.0));                                 // 28
  EXPECT_FALSE(monitor.add(10.0));                                 // 36
  EXPECT_TRUE(monitor.add(10.0));                                  // 44 > 40.00
  for (int i = 0; i < 7; ++i) EXPECT_TRUE(monitor.add(2.0)) << i;  // the old 2s leave: still 44
  EXPECT_FALSE(monitor.add(2.0));                                  // a 10 leaves: 36
  EXPECT_FALSE(monitor.add(std::numeric_limits<double>::quiet_NaN()));  // ignored
  EXPECT_FALSE(monitor.add(-1.0));                                      // ignored
  EXPECT_EQ(monitor.filled(), 10);
  for (int i = 0; i < 10; ++i) monitor.add(0.5);  // sum 5 < 7.43: smaller than the model expects
  EXPECT_TRUE(monitor.outside());
  monitor.reset();
  EXPECT_FALSE(monitor.outside());
  EXPECT_EQ(monitor.filled(), 0);
}

TEST(Envelope, InvalidSettingsNameTheField) {
  for (const auto& [settings, field] :
       {std::pair{EnvelopeSettings{0, 0.01}, "envelope.window"},
        std::pair{EnvelopeSettings{EnvelopeSettings::kMaxWindow + 1, 0.01}, "envelope.window"},
        std::pair{EnvelopeSettings{10, 0.0}, "envelope.significance"},
        std::pair{EnvelopeSettings{10, std::numeric_limits<double>::quiet_NaN()},
                  "envelope.significance"}}) {
    try {
      const EnvelopeMonitor monitor(settings);
      FAIL() << field;
    } catch (const InvalidParameter& error) {
      EXPECT_EQ(error.field(), field);
    }
  }
}

// A CV Kalman filter (a one-mode plain IMM) on a CV target with exactly its process and plot
// noise: its NIS is χ² with 2 degrees of freedom, so a window is flagged with the test's
// significance. Disjoint windows after the start are independent: the count of false alarms is
// binomial, and it must lie within 4 of its standard deviations of the nominal.
struct Simulation {
  double q = 0.04, sigma = 5.0;
  int tracks = 300, scans = 120;
};

PlainImmSpec kalman_filter(const Simulation& s) {
  PlainImmSpec spec;
  spec.sample_period = 1.0;
  spec.sample_period = 1.0;
  spec.modes = {{"cv", MotionKind::kConstantVelocity, s.q}};
  spec.transition = Eigen::MatrixXd::Ones(1, 1);
  spec.initial_probabilities = Eigen::VectorXd::Ones(1);
  spec.measurement.covariance = s.sigma * s.sigma * Eigen::Matrix2d::Identity();
  return spec;
}

TEST(Envelope, AConsistentFilterRaisesFalseAlarmsAtTheNominalRate) {
  const Simulation s;
  const EnvelopeSettings settings{10, 0.05};
  std::mt19937_64 rng(20261125);
  std::normal_distribution<double> normal;
  int windows = 0, alarms = 0;
  for (int track = 0; track < s.tracks; ++track) {
    TrackOptions options = kalman_filter(s).track_options(kDefaultMaxGap);
    options.envelope = settings;
    Tracker tracker(make_plain_imm_filter(kalman_filter(s)), options);
    Eigen::Vector4d x(0.0, 10.0, 0.0, -5.0);  // [x, vx, y, vy]
    for (int k = 0; k < s.scans; ++k) {
      for (int axis = 0; axis < 2; ++axis) {  // piecewise-constant white acceleration
        const double a = std::sqrt(s.q) * normal(rng);
        x(2 * axis) += x(2 * axis + 1) + 0.5 * a;
        x(2 * axis + 1) += a;
      }
      const Eigen::Vector2d z(x(0) + s.sigma * normal(rng), x(2) + s.sigma * normal(rng));
      const TrackStepResult result = tracker.process(k, z);
      // Disjoint full windows, after the two-point start has settled.
      if (k >= 30 && (k - 30) % settings.window == settings.window - 1) {
        ++windows;
        alarms += result.outside_envelope ? 1 : 0;
      }
    }
  }
  const double expected = windows * settings.significance;
  const double sd = std::sqrt(windows * settings.significance * (1.0 - settings.significance));
  std::cout << alarms << " false alarms in " << windows << " windows (nominal " << expected << " ± "
            << sd << ")\n";
  EXPECT_NEAR(alarms, expected, 4.0 * sd);
}

// The same filter on a target that manoeuvres with 3 × its largest plausible acceleration (a
// constant 3·3σ_a = 9√q turn-like acceleration from scan 60): the window is flagged within one
// window length of the onset in at least 95 % of the tracks.
TEST(Envelope, ManoeuvresBeyondTheModelAreFlaggedWithinAWindow) {
  const Simulation s;
  const EnvelopeSettings settings{10, 0.01};
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal;
  int flagged_in_time = 0;
  long delay_sum = 0;
  for (int track = 0; track < s.tracks; ++track) {
    TrackOptions options = kalman_filter(s).track_options(kDefaultMaxGap);
    options.envelope = settings;
    Tracker tracker(make_plain_imm_filter(kalman_filter(s)), options);
    Eigen::Vector4d x(0.0, 10.0, 0.0, -5.0);
    int first_flag = -1;
    for (int k = 0; k < 60 + settings.window; ++k) {
      const double push = k >= 60 ? 9.0 * std::sqrt(s.q) : 0.0;
      for (int axis = 0; axis < 2; ++axis) {
        const double a = std::sqrt(s.q) * normal(rng) + (axis == 1 ? push : 0.0);
        x(2 * axis) += x(2 * axis + 1) + 0.5 * a;
        x(2 * axis + 1) += a;
      }
      const Eigen::Vector2d z(x(0) + s.sigma * normal(rng), x(2) + s.sigma * normal(rng));
      if (tracker.process(k, z).outside_envelope && k >= 60 && first_flag < 0) first_flag = k;
    }
    flagged_in_time += first_flag >= 0 ? 1 : 0;
    delay_sum += first_flag >= 0 ? first_flag - 60 + 1 : 0;
  }
  std::cout << flagged_in_time << " of " << s.tracks << " tracks flagged within " << settings.window
            << " scans of the onset, after "
            << static_cast<double>(delay_sum) / std::max(flagged_in_time, 1)
            << " scans on average\n";
  EXPECT_GE(flagged_in_time, static_cast<int>(0.95 * s.tracks));
}

}  // namespace
}  // namespace imm
