// SPDX-License-Identifier: Apache-2.0
// Time stamps (track_filter.hpp, Tracker::process_at): a plain IMM predicts over any interval with
// F, Q and the mode transitions of that interval — against the Kalman filter of the interval
// written out here, and to the bit the scan-driven numbers at one sample period; a model built for
// one period takes whole numbers of periods and refuses other intervals without moving.

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "imm/estimation/mode_transitions.hpp"
#include "imm/load.hpp"
#include "imm/model_kinds.hpp"
#include "imm/tracking/plain_imm_track_bank.hpp"
#include "imm/tracking/track_bank.hpp"
#include "imm/tracking/tracker.hpp"
#include "testing/filter_snapshot.hpp"
#include "testing/kind_filters.hpp"
#include "testing/shipped_models.hpp"

namespace imm {
namespace {

using testing::Snapshot;
using testing::start_both;

// One CV mode (Π = [1]) with Cartesian plots of σ = 10 and q = 4.
PlainImmSpec one_cv_mode(NoiseForm form) {
  PlainImmSpec spec;
  spec.sample_period = 1.0;
  ModeSpec cv;
  cv.name = "cv";
  cv.process_noise = 4.0;
  cv.noise_form = form;
  spec.modes = {cv};
  spec.transition = Eigen::MatrixXd::Ones(1, 1);
  spec.initial_probabilities = Eigen::VectorXd::Ones(1);
  spec.measurement.covariance = Eigen::Matrix2d::Identity() * 100.0;
  return spec;
}

TEST(TimeStamps, ACvModeOverAnyIntervalIsTheKalmanFilterOfThatInterval) {
  for (const NoiseForm form : {NoiseForm::kPiecewiseConstant, NoiseForm::kContinuous}) {
    const PlainImmSpec spec = one_cv_mode(form);
    auto filter = make_plain_imm_filter(spec);
    ASSERT_TRUE(filter->takes_any_interval());
    Eigen::Vector4d x(100.0, 20.0, -50.0, 5.0);
    Eigen::Matrix4d P = Eigen::Vector4d(400.0, 100.0, 300.0, 50.0).asDiagonal();
    P(0, 1) = P(1, 0) = 30.0;
    filter->initialize(x, P);
    const double q = 4.0;
    Eigen::Matrix<double, 2, 4> H = Eigen::Matrix<double, 2, 4>::Zero();
    H(0, 0) = H(1, 2) = 1.0;
    const Eigen::Matrix2d R = spec.measurement.covariance;
    const double intervals[] = {0.37, 2.9, 0.05, 1.0, 7.25};
    for (const double dt : intervals) {
      SCOPED_TRACE(dt);
      // The Kalman filter over dt, written out: F = [1 dt; 0 1], Q of the noise form per axis.
      Eigen::Matrix4d F = Eigen::Matrix4d::Identity();
      F(0, 1) = F(2, 3) = dt;
      Eigen::Matrix2d axis_q;
      if (form == NoiseForm::kPiecewiseConstant) {
        axis_q << std::pow(dt, 4) / 4, std::pow(dt, 3) / 2, std::pow(dt, 3) / 2, dt * dt;
      } else {
        axis_q << std::pow(dt, 3) / 3, dt * dt / 2, dt * dt / 2, dt;
      }
      Eigen::Matrix4d Q = Eigen::Matrix4d::Zero();
      Q.block<2, 2>(0, 0) = Q.block<2, 2>(2, 2) = q * axis_q;
      const Eigen::Vector2d z(x(0) + 20.0 * dt + 7.0, x(2) + 5.0 * dt - 4.0);
      const Eigen::Vector4d x_pred = F * x;
      const Eigen::Matrix4d P_pred = F * P * F.transpose() + Q;
      const Eigen::Matrix2d S = H * P_pred * H.transpose() + R;
      const Eigen::Matrix<double, 4, 2> K = P_pred * H.transpose() * S.inverse();
      x = x_pred + K * (z - H * x_pred);
      const Eigen::Matrix4d I_KH = Eigen::Matrix4d::Identity() - K * H;
      P = I_KH * P_pred * I_KH.transpose() + K * R * K.transpose();

      ASSERT_EQ(step_over(*filter, spec.sample_period, dt, z), StepStatus::kOk);
      Eigen::VectorXd mean(4), variance(4);
      Eigen::MatrixXd covariance(4, 4);
      filter->state(mean, variance);
      filter->covariance(covariance);
      for (int i = 0; i < 4; ++i) {
        EXPECT_NEAR(mean(i), x(i), 1e-10 * std::max(1.0, std::abs(x(i)))) << i;
        for (int j = 0; j < 4; ++j) {
          EXPECT_NEAR(covariance(i, j), P(i, j), 1e-10 * P.cwiseAbs().maxCoeff()) << i << j;
        }
      }
    }
  }
}

TEST(TimeStamps, ModeTransitionsOverAnIntervalKeepEachModesMeanSojournTime) {
  ModeMatrix per_period(3, 3);
  per_period << 0.9, 0.06, 0.04, 0.2, 0.7, 0.1, 0.0, 0.0, 1.0;
  ModeMatrix out;
  transition_over(per_period, 1.0, out);
  EXPECT_EQ(std::memcmp(out.data(), per_period.data(), sizeof(double) * 9), 0);
  for (const double periods : {0.01, 0.5, 2.0, 3.7, 50.0}) {
    SCOPED_TRACE(periods);
    transition_over(per_period, periods, out);
    ASSERT_EQ(out.rows(), 3);
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(out.row(i).sum(), 1.0, 1e-15);
      EXPECT_GE(out.row(i).minCoeff(), 0.0);
      // Mean sojourn −Δt / ln p_ii(Δt) = −T / ln p_ii at every interval.
      if (per_period(i, i) < 1.0) {
        EXPECT_NEAR(-periods / std::log(out(i, i)), -1.0 / std::log(per_period(i, i)), 1e-9);
        // A switch goes where Π sends it: the off-diagonal entries keep their ratios.
        EXPECT_NEAR(out(i, (i + 1) % 3) * per_period(i, (i + 2) % 3),
                    out(i, (i + 2) % 3) * per_period(i, (i + 1) % 3), 1e-15);
      }
    }
    EXPECT_EQ(out(2, 2), 1.0);  // never left
  }
  // Two periods of a two-mode chain stay in a mode with p², as Π² does.
  ModeMatrix two(2, 2);
  two << 0.95, 0.05, 0.1, 0.9;
  transition_over(two, 2.0, out);
  EXPECT_DOUBLE_EQ(out(0, 0), 0.95 * 0.95);
  EXPECT_DOUBLE_EQ(out(1, 0), 1.0 - 0.9 * 0.9);
  // A short interval barely switches.
  transition_over(two, 1e-6, out);
  EXPECT_NEAR(out(0, 0), 1.0, 1e-7);
}

TEST(TimeStamps, WholePeriodsWithinTheToleranceAndNoOthers) {
  EXPECT_EQ(whole_periods(1.0, 1.0), 1);
  EXPECT_EQ(whole_periods(3.0, 1.0), 3);
  EXPECT_EQ(whole_periods(2.0 + 0.9 * kIntervalTolerance, 1.0), 2);
  EXPECT_EQ(whole_periods(2.0 - 0.9 * kIntervalTolerance * 0.1, 0.1 * 10.0), 2);
  EXPECT_EQ(whole_periods(2.0 + 1.5 * kIntervalTolerance, 1.0), 0);
  EXPECT_EQ(whole_periods(0.5, 1.0), 0);
  EXPECT_EQ(whole_periods(1.5, 1.0), 0);
  EXPECT_EQ(whole_periods(0.0, 1.0), 0);
  EXPECT_EQ(whole_periods(-1.0, 1.0), 0);
  EXPECT_EQ(whole_periods(std::nan(""), 1.0), 0);
  EXPECT_EQ(whole_periods(1.0, std::nan("")), 0);
  EXPECT_EQ(whole_periods(1e300, 1.0), 0);
}

// Every shipped model: one sample period through step_over() and predict_over() gives step()'s
// bits; a filter of one period takes two periods as a predict_only() and a step(), and refuses
// one and a half without moving.
TEST(TimeStamps, OnePeriodIsTheStepToTheBitAndOtherIntervalsAreTakenOrRefused) {
  int any = 0, fixed = 0;
  for (const auto& path : testing::shipped_models()) {
    SCOPED_TRACE(path.string());
    LoadedFilter by_scan = load_filter(path), by_time = load_filter(path);
    const double T = by_scan.options.sample_period;
    const auto plots = testing::seeded_plots(by_scan.options, 9, 40);
    start_both(*by_scan.filter, *by_time.filter, by_scan.options, plots.front().second);
    TrackFilter& a = *by_scan.filter;
    TrackFilter& b = *by_time.filter;
    (a.takes_any_interval() ? any : fixed) += 1;
    std::int64_t last = plots.front().first;
    for (std::size_t i = 1; i < plots.size(); ++i) {
      const auto& [k, z] = plots[i];
      const double interval = static_cast<double>(k - last) * T;
      if (!b.takes_any_interval()) {
        // One and a half periods: refused, nothing moved.
        const Snapshot before(b);
        EXPECT_EQ(step_over(b, T, 1.5 * T, z), StepStatus::kUnsupportedInterval);
        ASSERT_TRUE(Snapshot(b) == before);
        for (; last + 1 < k; ++last) ASSERT_EQ(a.predict_only(), StepStatus::kOk);
        ASSERT_EQ(step_over(b, T, interval, z), a.step(z)) << k;
      } else if (interval == T && i % 2 == 0 && b.predicts_before_the_plot()) {
        ASSERT_EQ(a.predict(), StepStatus::kOk);
        ASSERT_EQ(predict_over(b, T, T), StepStatus::kOk);
        ASSERT_EQ(b.update(z), a.update(z));
      } else {
        // Skipped scans predicted one period at a time, then the plot.
        for (; last + 1 < k; ++last) ASSERT_EQ(predict_only_over(b, T, T), a.predict_only());
        ASSERT_EQ(step_over(b, T, T, z), a.step(z)) << k;
      }
      last = k;
      ASSERT_TRUE(Snapshot(a) == Snapshot(b)) << "scan " << k;
      ASSERT_EQ(a.mode_probabilities(), b.mode_probabilities());
    }
  }
  EXPECT_GE(any, 5);    // the plain IMMs without a schedule
  EXPECT_GE(fixed, 6);  // every learned kind, the scheduled IMMs
}

// A CV target seen at irregular times (0.2 to 3 s apart) by a CV/CT IMM: driven by the times it
// is consistent; driven by scan numbers, as if the plots were one period apart, it is not.
TEST(TimeStamps, ATrackerFedIrregularTimesTracksWhatScansCannot) {
  PlainImmSpec spec = one_cv_mode(NoiseForm::kPiecewiseConstant);
  ModeSpec ct;
  ct.name = "ct";
  ct.motion = MotionKind::kCoordinatedTurn;
  ct.process_noise = 4.0;
  ct.turn_noise = 1e-6;
  spec.modes.push_back(ct);
  spec.transition.resize(2, 2);
  spec.transition << 0.95, 0.05, 0.05, 0.95;
  spec.initial_probabilities = Eigen::Vector2d(0.5, 0.5);
  spec.initialization.turn_rate_variance = 1e-4;
  PlainImmTracker by_time(spec), by_scan(spec);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> gap(0.2, 3.0);
  std::normal_distribution<double> noise(0.0, 10.0);
  double t = 100.0, nis_time = 0.0, nis_scan = 0.0, squared_error = 0.0;
  int updates = 0;
  for (int k = 0; k < 300; ++k) {
    t += gap(rng);
    const Eigen::Vector2d truth(1000.0 + 150.0 * t, -500.0 + 80.0 * t);
    const Eigen::Vector2d z = truth + Eigen::Vector2d(noise(rng), noise(rng));
    const auto timed = by_time.process_at(t, z);
    const auto scanned = by_scan.process(k, z);
    ASSERT_NE(timed.event, TrackEvent::kRejected) << timed.reason;
    ASSERT_EQ(by_time.last_time(), t);
    if (k < 20 || timed.event != TrackEvent::kUpdated || scanned.event != TrackEvent::kUpdated) {
      continue;
    }
    nis_time += *last_step_nis(by_time.filter());
    nis_scan += *last_step_nis(by_scan.filter());
    Eigen::VectorXd mean(5), variance(5);
    by_time.state(mean, variance);
    squared_error += (Eigen::Vector2d(mean(0), mean(2)) - truth).squaredNorm();
    ++updates;
  }
  ASSERT_GT(updates, 250);
  const double mean_nis = nis_time / updates;
  EXPECT_GT(mean_nis, 1.0);
  EXPECT_LT(mean_nis, 2.6);
  EXPECT_LT(std::sqrt(squared_error / updates), 10.0 * std::sqrt(2.0));
  EXPECT_GT(nis_scan / updates, 10.0 * mean_nis);
}

// The banks take a scan's interval for all their tracks: TrackBank equals one-track IMMs given
// the same intervals (to rounding, as at one period), PlainImmTrackBank to the bit; a bank of a
// model of one period refuses.
TEST(TimeStamps, BanksTakeTheIntervalOfAScanForEveryTrack) {
  PlainImmSpec cv2 = one_cv_mode(NoiseForm::kContinuous);
  ModeSpec fast = cv2.modes.front();
  fast.name = "fast";
  fast.process_noise = 400.0;
  fast.noise_form = NoiseForm::kPiecewiseConstant;
  cv2.modes.push_back(fast);
  cv2.transition.resize(2, 2);
  cv2.transition << 0.9, 0.1, 0.2, 0.8;
  cv2.initial_probabilities = Eigen::Vector2d(0.7, 0.3);
  constexpr std::size_t kTracks = 9;
  TrackBank bank(cv2, kTracks);
  PlainImmTrackBank<4> plain_bank(cv2, kTracks);
  std::vector<ImmEstimator<4, 2>> alone;
  GaussianState<4> start;
  start.covariance *= 400.0;
  for (std::size_t t = 0; t < kTracks; ++t) {
    start.mean << 10.0 * t, 20.0, -5.0 * t, 3.0;
    bank.initialize(t, start);
    plain_bank.initialize(t, start);
    alone.push_back(build_plain_imm<4>(cv2));
    alone.back().initialize(start);
  }
  EXPECT_FALSE(bank.set_interval(0.0));
  EXPECT_FALSE(plain_bank.set_interval(std::nan("")));
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> gap(0.1, 4.0);
  std::normal_distribution<double> noise(0.0, 10.0);
  std::vector<Eigen::Vector2d> plots(kTracks);
  std::vector<StepStatus> status(kTracks), plain_status(kTracks);
  double t_now = 0.0;
  for (int k = 0; k < 60; ++k) {
    const double dt = k % 10 == 0 ? 1.0 : gap(rng);
    t_now += dt;
    ASSERT_TRUE(bank.set_interval(dt));
    ASSERT_TRUE(plain_bank.set_interval(dt));
    for (std::size_t t = 0; t < kTracks; ++t) {
      plots[t] = Eigen::Vector2d(10.0 * t + 20.0 * t_now, -5.0 * t + 3.0 * t_now) +
                 Eigen::Vector2d(noise(rng), noise(rng));
    }
    bank.step(plots, status);
    plain_bank.step(plots, plain_status);
    for (std::size_t t = 0; t < kTracks; ++t) {
      ASSERT_TRUE(alone[t].set_interval(dt, dt / cv2.sample_period));
      ASSERT_EQ(alone[t].step(plots[t]), StepStatus::kOk);
      ASSERT_EQ(status[t], StepStatus::kOk);
      ASSERT_EQ(plain_status[t], StepStatus::kOk);
      const GaussianState<4> a = alone[t].estimate(), b = bank.estimate(t);
      const GaussianState<4> c = plain_bank.estimate(t);
      EXPECT_EQ(std::memcmp(a.mean.data(), c.mean.data(), sizeof(double) * 4), 0);
      EXPECT_EQ(std::memcmp(a.covariance.data(), c.covariance.data(), sizeof(double) * 16), 0);
      for (int i = 0; i < 4; ++i) {
        EXPECT_NEAR(b.mean(i), a.mean(i), 1e-9 * std::max(1.0, std::abs(a.mean(i))));
        EXPECT_NEAR(b.covariance(i, i), a.covariance(i, i), 1e-9 * a.covariance(i, i));
      }
      EXPECT_NEAR(bank.mode_probabilities(t)(1), alone[t].mode_probabilities()(1), 1e-9);
    }
  }
  // Any kind's bank behind one interface: a model of one period refuses an interval.
  for (const auto& path : testing::shipped_models()) {
    const LoadedFilter loaded = load_filter(path);
    std::unique_ptr<AnyTrackBank> any = open_track_bank(path, 2);
    EXPECT_EQ(any->set_interval(0.5 * loaded.options.sample_period),
              loaded.filter->takes_any_interval())
        << path;
  }
}

TEST(TimeStamps, ATrackerRefusesTimesThatDoNotIncreaseMixedClocksAndOddIntervals) {
  PlainImmTracker plain(one_cv_mode(NoiseForm::kPiecewiseConstant));
  EXPECT_EQ(plain.process_at(10.0, {0.0, 0.0}).event, TrackEvent::kWaiting);
  const TrackStepResult again = plain.process_at(10.0, {1.0, 0.0});
  EXPECT_EQ(again.event, TrackEvent::kRejected);
  EXPECT_EQ(again.status, StepStatus::kUnsupportedInterval);  // the interval, not the plot
  EXPECT_EQ(plain.process_at(std::nan(""), {1.0, 0.0}).event, TrackEvent::kRejected);
  EXPECT_EQ(plain.process(3, {1.0, 0.0}).event, TrackEvent::kRejected);
  EXPECT_EQ(plain.process_at(10.4, {1.0, 0.0}).event, TrackEvent::kInitialized);
  EXPECT_FALSE(plain.last_scan().has_value());

  PlainImmTracker scans(one_cv_mode(NoiseForm::kPiecewiseConstant));
  EXPECT_EQ(scans.process(5, {0.0, 0.0}).event, TrackEvent::kWaiting);
  EXPECT_EQ(scans.process(5, {1.0, 0.0}).status, StepStatus::kUnsupportedInterval);
  EXPECT_EQ(scans.process(4, {1.0, 0.0}).status, StepStatus::kUnsupportedInterval);

  // Two plots too close in time for a finite velocity (1e-300 s apart): the later one is the first
  // plot now, and the next plot starts the track from it.
  PlainImmTracker close(one_cv_mode(NoiseForm::kPiecewiseConstant));
  EXPECT_EQ(close.process_at(0.0, {0.0, 0.0}).event, TrackEvent::kWaiting);
  EXPECT_EQ(close.process_at(1e-300, {1.0, 1.0}).event, TrackEvent::kWaiting);
  EXPECT_FALSE(close.initialized());
  EXPECT_EQ(close.process_at(2.0, {3.0, 0.0}).event, TrackEvent::kInitialized);
  Eigen::VectorXd mean(4), variance(4);
  close.state(mean, variance);
  EXPECT_EQ(mean(1), 1.0);   // (3 − 1) / (2 − 1e-300)
  EXPECT_EQ(mean(3), -0.5);  // (0 − 1) / 2
  // Plots 1e-12 s apart: finite, but shorter than any interval a filter takes (1 µs). The start
  // they once gave (10¹² m/s, a velocity variance 2·10²⁴ times the position's) made the second
  // update non-finite; the later plot is now the first, and the track that starts from it runs.
  PlainImmTracker near(one_cv_mode(NoiseForm::kPiecewiseConstant));
  EXPECT_EQ(near.process_at(0.0, {0.0, 0.0}).event, TrackEvent::kWaiting);
  EXPECT_EQ(near.process_at(1e-12, {1.0, 0.0}).event, TrackEvent::kWaiting);
  EXPECT_EQ(near.process_at(1.0, {11.0, 0.0}).event, TrackEvent::kInitialized);
  for (int k = 2; k < 6; ++k) {
    const TrackStepResult result = near.process_at(k, {1.0 + 10.0 * k, 0.0});
    EXPECT_EQ(result.event, TrackEvent::kUpdated) << k << ": " << result.reason;
  }
  near.state(mean, variance);
  EXPECT_NEAR(mean(1), 10.0, 1e-9);  // a straight line at 10 m/s, fitted exactly
  PlainImmTracker micro(one_cv_mode(NoiseForm::kPiecewiseConstant));
  EXPECT_EQ(micro.process_at(0.0, {0.0, 0.0}).event, TrackEvent::kWaiting);
  EXPECT_EQ(micro.process_at(2e-6, {1e-5, 0.0}).event, TrackEvent::kInitialized);  // 5 m/s
  const TrackOptions options = one_cv_mode(NoiseForm::kPiecewiseConstant).track_options(50);
  // Faster than any target (limits::kSpeed, 10⁶ per second): no start.
  EXPECT_FALSE(two_point_start(options, 4, 0, {0.0, 0.0}, 1, {2e6, 0.0}).has_value());
  EXPECT_TRUE(two_point_start(options, 4, 0, {0.0, 0.0}, 1, {0.9e6, 0.0}).has_value());
  // A velocity beyond the doubles (plots ±1e308 apart): no start.
  EXPECT_FALSE(two_point_start(options, 4, 0, {-1e308, 0.0}, 1, {1e308, 0.0}).has_value());
  EXPECT_TRUE(two_point_start(options, 4, 0, {-1e3, 0.0}, 1, {1e3, 0.0}).has_value());

  // A learned model (of one period) fed times: whole periods only.
  for (const auto& path : testing::shipped_models()) {
    LoadedFilter loaded = load_filter(path);
    if (loaded.filter->takes_any_interval()) continue;
    SCOPED_TRACE(path.string());
    const TrackOptions learned = loaded.options;
    Tracker tracker(std::move(loaded.filter), learned);
    const double T = learned.sample_period;
    const auto plots = testing::seeded_plots(learned, 4, 6);
    ASSERT_NE(tracker.process_at(0.0, plots[0].second).event, TrackEvent::kRejected);
    ASSERT_NE(tracker.process_at(T, plots[1].second).event, TrackEvent::kRejected);
    ASSERT_EQ(tracker.last_time(), T);
    const auto odd = tracker.process_at(2.5 * T, plots[2].second);
    EXPECT_EQ(odd.event, TrackEvent::kRejected);
    EXPECT_EQ(odd.status, StepStatus::kUnsupportedInterval);
    EXPECT_EQ(tracker.last_time(), T);
    const auto two =
        tracker.process_at(3.0 * T * (1.0 + 0.3 * kIntervalTolerance), plots[3].second);
    EXPECT_EQ(two.event, TrackEvent::kUpdated) << two.reason;
    EXPECT_EQ(two.predicted_scans, 1);
    break;
  }
}

}  // namespace
}  // namespace imm
