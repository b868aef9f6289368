// SPDX-License-Identifier: Apache-2.0
// The bank of any plain IMM (CV, CA and coordinated-turn modes, Cartesian or polar plots): each of
// its tracks learns its own turn rate from noise-free turns (the truth is the reference), a track
// is the one-track IMM of the same spec to the bit, a failed step leaves its track untouched
// while the others go on, and bad arguments are refused naming the field.

#include "imm/tracking/plain_imm_track_bank.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/models/motion/coordinated_turn.hpp"
#include "imm/tracking/track_bank.hpp"
#include "testing/specs.hpp"

namespace imm {
namespace {

constexpr double kBankPeriod = 1.0;

using testing::mode_spec;

PlainImmSpec bank_spec_of(std::vector<ModeSpec> modes, MeasurementKind kind, Eigen::Matrix2d R) {
  return testing::switching_spec(std::move(modes), kBankPeriod, 0.05, kind, R);
}

// [x, vx, y, vy, ω] → the bank's mixing space of NX states.
template <int NX>
Vector<NX> embed(const Vector<5>& s) {
  Vector<NX> x = Vector<NX>::Zero();
  const int y = NX == 5 ? 2 : 3;
  x(0) = s(0), x(1) = s(1), x(y) = s(2), x(y + 1) = s(3), x(NX - 1) = s(4);
  return x;
}

// Tracks of one bank, each on its own noise-free turn (one at ω = 0), started with ω = 0 and
// plots of small noise: every track's ω estimate lies within 3σ of its own turn rate, σ small.
template <int NX>
void expect_each_track_learns_its_turn(const PlainImmSpec& spec, double noise,
                                       const Eigen::Vector2d& sensor) {
  const std::vector<double> rates{0.05, -0.03, 0.0, 0.02, -0.06};
  const std::size_t n = rates.size();
  PlainImmTrackBank<NX> bank(spec, n);
  std::vector<Vector<5>> truth(n);
  for (std::size_t t = 0; t < n; ++t) {
    truth[t] << 20000.0 + 1000.0 * static_cast<double>(t), 150.0, 15000.0, -40.0, rates[t];
    Vector<5> start = truth[t];
    start(4) = 0.0;
    GaussianState<NX> state;
    state.mean = embed<NX>(start);
    state.covariance = SquareMatrix<NX>::Identity() * 100.0;
    state.covariance(NX - 1, NX - 1) = 0.01;
    bank.initialize(t, state);
  }
  std::mt19937_64 rng(11);
  std::normal_distribution<double> unit(0.0, 1.0);
  std::vector<Eigen::Vector2d> plots(n);
  std::vector<StepStatus> status(n);
  for (int k = 0; k < 120; ++k) {
    for (std::size_t t = 0; t < n; ++t) {
      truth[t] = coordinated_turn_step(truth[t], kBankPeriod);
      const Eigen::Vector2d p(truth[t](0) - sensor(0), truth[t](2) - sensor(1));
      plots[t] = spec.measurement.kind == MeasurementKind::kCartesian
                     ? Eigen::Vector2d(p(0) + noise * unit(rng), p(1) + noise * unit(rng))
                     : Eigen::Vector2d(p.norm() + noise * unit(rng),
                                       std::atan2(p(0), p(1)) + 1e-4 * unit(rng));
    }
    bank.step(plots, status);
    for (std::size_t t = 0; t < n; ++t) ASSERT_EQ(status[t], StepStatus::kOk) << t << " at " << k;
  }
  for (std::size_t t = 0; t < n; ++t) {
    SCOPED_TRACE(rates[t]);
    const GaussianState<NX> e = bank.estimate(t);
    const double sigma = std::sqrt(e.covariance(NX - 1, NX - 1));
    EXPECT_NEAR(e.mean(NX - 1), rates[t], 3.0 * sigma);
    EXPECT_LT(sigma, 0.01);
    EXPECT_NEAR(bank.mode_probabilities(t).sum(), 1.0, 1e-12);
  }
}

TEST(PlainImmTrackBank, EveryTrackOfACvCaCtBankLearnsItsOwnTurnRate) {
  const PlainImmSpec spec = bank_spec_of({mode_spec("cv", MotionKind::kConstantVelocity, 0.1),
                                          mode_spec("ca", MotionKind::kConstantAcceleration, 1.0),
                                          mode_spec("ct", MotionKind::kCoordinatedTurn, 0.1, 1e-6)},
                                         MeasurementKind::kCartesian, Eigen::Matrix2d::Identity());
  ASSERT_EQ(spec.mixing_dimension(), 7);
  expect_each_track_learns_its_turn<7>(spec, 1.0, Eigen::Vector2d::Zero());
}

// Range and azimuth (clockwise from the y axis, polar_measurement.hpp) of turns 25 km out.
TEST(PlainImmTrackBank, PolarPlotsOfTurnsAroundTheSensor) {
  Eigen::Matrix2d R = Eigen::Matrix2d::Zero();
  R(0, 0) = 1.0;
  R(1, 1) = 1e-8;
  const PlainImmSpec spec = bank_spec_of({mode_spec("cv", MotionKind::kConstantVelocity, 0.1),
                                          mode_spec("ct", MotionKind::kCoordinatedTurn, 0.1, 1e-6)},
                                         MeasurementKind::kPolar, R);
  ASSERT_EQ(spec.mixing_dimension(), 5);
  expect_each_track_learns_its_turn<5>(spec, 1.0, Eigen::Vector2d::Zero());
}

// A track is the one-track IMM of the spec (the same step, not a copy of it): fed the same plots
// it holds the same estimate to the bit; an unusable plot leaves its own track exactly as it was,
// with its status, and the other tracks step.
TEST(PlainImmTrackBank, ATrackIsTheOneTrackImmAndAFailedStepChangesOnlyItsTrack) {
  const PlainImmSpec spec =
      bank_spec_of({mode_spec("cv", MotionKind::kConstantVelocity, 0.1),
                    mode_spec("ct", MotionKind::kCoordinatedTurn, 1.0, 1e-4)},
                   MeasurementKind::kCartesian, 25.0 * Eigen::Matrix2d::Identity());
  PlainImmTrackBank<5> bank(spec, 3);
  auto single = build_plain_imm<5>(spec);
  GaussianState<5> start;
  start.mean << 0.0, 100.0, 0.0, 50.0, 0.0;
  start.covariance = Vector<5>(100.0, 25.0, 100.0, 25.0, 0.001).asDiagonal();
  for (std::size_t t = 0; t < 3; ++t) bank.initialize(t, start);
  single.initialize(start);
  std::vector<StepStatus> status(3);
  for (int k = 1; k <= 20; ++k) {
    const Eigen::Vector2d z(100.0 * k + 3.0 * std::sin(k), 50.0 * k + 0.2 * k * k);
    std::vector<Eigen::Vector2d> plots{z, z, z};
    const bool gap = k == 10;
    const GaussianState<5> before = bank.estimate(1);
    if (gap) plots[1] = Eigen::Vector2d(std::numeric_limits<double>::quiet_NaN(), 0.0);
    bank.step(plots, status);
    ASSERT_EQ(single.step(z), StepStatus::kOk);
    EXPECT_EQ(status[0], StepStatus::kOk);
    EXPECT_EQ(status[1], gap ? StepStatus::kInvalidMeasurement : StepStatus::kOk);
    EXPECT_EQ(bank.estimate(0).mean, single.estimate().mean) << k;
    EXPECT_EQ(bank.estimate(0).covariance, single.estimate().covariance) << k;
    if (gap) {
      EXPECT_EQ(bank.estimate(1).mean, before.mean);
      EXPECT_EQ(bank.estimate(1).covariance, before.covariance);
    }
  }
  EXPECT_EQ(bank.log_mode_probabilities(0), single.log_mode_probabilities());
  EXPECT_NE(bank.estimate(1).mean, bank.estimate(0).mean);  // it missed a plot
}

TEST(PlainImmTrackBank, BadArgumentsAreRefusedNamingTheField) {
  const PlainImmSpec spec = bank_spec_of({mode_spec("cv", MotionKind::kConstantVelocity, 0.1),
                                          mode_spec("ct", MotionKind::kCoordinatedTurn, 1.0, 1e-4)},
                                         MeasurementKind::kCartesian, Eigen::Matrix2d::Identity());
  const auto field_of = [](auto&& make) {
    try {
      make();
    } catch (const InvalidParameter& error) {
      return error.field();
    }
    return std::string("none");
  };
  EXPECT_EQ(field_of([&] { PlainImmTrackBank<4> wrong(spec, 2); }), "modes");
  EXPECT_EQ(field_of([&] { PlainImmTrackBank<5> empty(spec, 0); }), "capacity");
  EXPECT_EQ(field_of([&] { TrackBank cv_only(spec, 2); }), "modes[1].motion");
  PlainImmTrackBank<5> bank(spec, 2);
  GaussianState<5> bad;
  bad.mean.setZero();
  bad.covariance = SquareMatrix<5>::Identity();
  bad.covariance(2, 2) = -1.0;
  EXPECT_EQ(field_of([&] { bank.initialize(0, bad); }), "initial_covariance");
  EXPECT_THROW(bank.initialize(2, GaussianState<5>{}), std::out_of_range);
  std::vector<Eigen::Vector2d> plots(2, Eigen::Vector2d::Zero());
  std::vector<StepStatus> status(2);
  EXPECT_THROW(bank.step(plots, status), std::logic_error);  // never initialized
  status.resize(1);
  EXPECT_THROW(bank.step(plots, status), std::invalid_argument);
}

}  // namespace
}  // namespace imm
