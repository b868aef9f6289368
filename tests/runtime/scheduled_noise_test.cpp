// SPDX-License-Identifier: Apache-2.0
// Learned noise schedules on the classical IMM's modes (imm/estimation/scheduled_noise_mode.hpp),
// against independent references: a schedule that answers a constant c everywhere is the
// unscheduled IMM with every intensity times c (Q is linear in them); one scheduled step equals the
// step written out by hand with dynamic matrices, its table included; the model file carries the
// schedules as a version-3 field; refusals name the field.

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>
#include <random>

#include "imm/filters/plain_imm.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/models/motion/coordinated_turn.hpp"
#include "imm/tracking/track_bank.hpp"
#include "testing/model_files.hpp"
#include "testing/specs.hpp"
#include "testing/temp_dir.hpp"

namespace imm {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr double kSchedulePeriod = 1.5;

using testing::mode_spec;

PlainImmSpec schedule_spec_of(std::vector<ModeSpec> modes, MeasurementKind kind) {
  const Eigen::Matrix2d R = kind == MeasurementKind::kCartesian
                                ? Eigen::Matrix2d(25.0 * Eigen::Matrix2d::Identity())
                                : Eigen::Matrix2d(Eigen::Vector2d(25.0, 1e-6).asDiagonal());
  return testing::switching_spec(std::move(modes), kSchedulePeriod, 0.04, kind, R);
}

// A 3 × 3 table over (d, Δd) whose consequents are all `w`.
FuzzyRuleTable constant_table(double w) {
  std::vector<FuzzyRule> rules;
  for (const double c1 : {0.5, 2.0, 4.0}) {
    for (const double c2 : {-2.0, 0.0, 2.0}) rules.push_back({c1, 0.8, c2, 1.0, w});
  }
  return FuzzyRuleTable(rules);
}

// A turning target's plots (Cartesian or polar, with the spec's R), one missed every ninth scan.
std::vector<std::optional<Eigen::Vector2d>> turning_plots(MeasurementKind kind, int scans) {
  Vector<5> truth;
  truth << 3000.0, 120.0, 1500.0, -40.0, 0.0;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<std::optional<Eigen::Vector2d>> plots;
  for (int k = 0; k < scans; ++k) {
    truth(4) = k > 15 && k < 35 ? 0.06 : 0.0;
    truth = coordinated_turn_step(truth, kSchedulePeriod);
    if (k % 9 == 8) {
      plots.emplace_back();
      continue;
    }
    if (kind == MeasurementKind::kCartesian) {
      plots.emplace_back(
          Eigen::Vector2d(truth(0) + 5.0 * normal(rng), truth(2) + 5.0 * normal(rng)));
    } else {
      plots.emplace_back(Eigen::Vector2d(std::hypot(truth(0), truth(2)) + 5.0 * normal(rng),
                                         std::atan2(truth(2), truth(0)) + 1e-3 * normal(rng)));
    }
  }
  return plots;
}

template <int NX>
void expect_same_run(const PlainImmSpec& a, const PlainImmSpec& b, MeasurementKind kind) {
  auto left = build_plain_imm<NX>(a);
  auto right = build_plain_imm<NX>(b);
  GaussianState<NX> start;
  start.mean.setZero();
  start.mean(0) = 3000.0;
  start.mean(NX >= 6 ? 3 : 2) = 1500.0;
  start.covariance = Vector<NX>::Constant(100.0).asDiagonal();
  start.covariance(NX - 1, NX - 1) = 0.01;
  left.initialize(start);
  right.initialize(start);
  int k = 0;
  for (const auto& plot : turning_plots(kind, 60)) {
    SCOPED_TRACE(k++);
    if (plot) {
      ASSERT_EQ(left.step(*plot), StepStatus::kOk);
      ASSERT_EQ(right.step(*plot), StepStatus::kOk);
    } else {
      ASSERT_EQ(left.predict_only(), StepStatus::kOk);
      ASSERT_EQ(right.predict_only(), StepStatus::kOk);
    }
    const double scale = right.estimate().mean.norm();
    ASSERT_LT((left.estimate().mean - right.estimate().mean).norm(), 1e-10 * scale);
    ASSERT_LT((left.estimate().covariance - right.estimate().covariance).norm(),
              1e-10 * right.estimate().covariance.norm());
    ASSERT_LT((left.mode_probabilities() - right.mode_probabilities()).norm(), 1e-10);
  }
}

// s ≡ c is Q·c: the scheduled IMM equals the classical IMM with every intensity times c, over CV +
// CT (5 states) and CV + CA + CT (7 states), Cartesian and polar plots, missed plots included.
TEST(ScheduledNoise, AConstantScheduleScalesEveryIntensity) {
  for (const double c : {1.0, 2.5, 0.3}) {
    for (const MeasurementKind kind : {MeasurementKind::kCartesian, MeasurementKind::kPolar}) {
      SCOPED_TRACE(std::to_string(c) + (kind == MeasurementKind::kPolar ? " polar" : " cartesian"));
      const std::vector<ModeSpec> five = {mode_spec("cv", MotionKind::kConstantVelocity, 0.05),
                                          mode_spec("ct", MotionKind::kCoordinatedTurn, 0.5, 1e-4)};
      const std::vector<ModeSpec> seven = {
          mode_spec("cv", MotionKind::kConstantVelocity, 0.05),
          mode_spec("ca", MotionKind::kConstantAcceleration, 0.2),
          mode_spec("ct", MotionKind::kCoordinatedTurn, 0.5, 1e-4)};
      for (const auto& modes : {five, seven}) {
        PlainImmSpec scheduled = schedule_spec_of(modes, kind);
        PlainImmSpec scaled = scheduled;
        for (std::size_t j = 0; j < modes.size(); ++j) {
          scheduled.modes[j].noise_schedule = constant_table(c);
          scaled.modes[j].process_noise *= c;
          scaled.modes[j].turn_noise *= c;
        }
        if (modes.size() == 2) {
          expect_same_run<5>(scheduled, scaled, kind);
        } else {
          expect_same_run<7>(scheduled, scaled, kind);
        }
      }
    }
  }
}

// One CV mode, Cartesian plots, a two-rule table: two steps written out with dynamic matrices —
// P̄ = F P Fᵀ, S̄ = H P̄ Hᵀ + R, d = √(ν̄ᵀ S̄⁻¹ ν̄), s from eq. (19-5) evaluated here, P⁻ = P̄ + s Q,
// then the Kalman update; the second step reads Δd = d(2) − d(1).
TEST(ScheduledNoise, OneStepIsTheHandWrittenStep) {
  const double q = 0.3;
  const std::vector<FuzzyRule> rules = {{0.0, 1.0, 0.0, 1.5, 0.2}, {3.0, 1.0, 1.0, 1.5, 9.0}};
  PlainImmSpec spec = schedule_spec_of({mode_spec("cv", MotionKind::kConstantVelocity, q)},
                                       MeasurementKind::kCartesian);
  spec.modes[0].noise_schedule = FuzzyRuleTable(rules);
  auto imm = build_plain_imm<4>(spec);
  GaussianState<4> start;
  start.mean << 0.0, 10.0, 0.0, -5.0;
  start.covariance = Vector<4>(30.0, 4.0, 30.0, 4.0).asDiagonal();
  imm.initialize(start);

  const LinearMotionModel<4> cv = constant_velocity<2>(kSchedulePeriod, q);
  const MatrixXd F = cv.transition, Q = cv.process_noise;
  MatrixXd H = MatrixXd::Zero(2, 4);
  H(0, 0) = 1.0;
  H(1, 2) = 1.0;
  const MatrixXd R = spec.measurement.covariance;
  VectorXd x = start.mean;
  MatrixXd P = start.covariance;
  double previous_d = 0.0;
  const auto table = [&](double d, double dd) {
    double num = 0.0, den = 0.0;
    for (const FuzzyRule& r : rules) {
      const double f = std::exp(
          -0.5 * (std::pow((d - r.c1) / r.sigma1, 2) + std::pow((dd - r.c2) / r.sigma2, 2)));
      num += r.w * f;
      den += f;
    }
    return num / den;
  };
  for (const Eigen::Vector2d& z : {Eigen::Vector2d(25.0, -4.0), Eigen::Vector2d(60.0, -30.0)}) {
    const VectorXd xp = F * x;
    const MatrixXd Pbar = F * P * F.transpose();
    const VectorXd nu = z - H * xp;
    const MatrixXd Sbar = H * Pbar * H.transpose() + R;
    const double d = std::sqrt(nu.dot(Sbar.inverse() * nu));
    const double s = table(d, d - previous_d);
    previous_d = d;
    const MatrixXd Pp = Pbar + s * Q;
    const MatrixXd S = H * Pp * H.transpose() + R;
    const MatrixXd K = Pp * H.transpose() * S.inverse();
    x = xp + K * nu;
    const MatrixXd I_KH = MatrixXd::Identity(4, 4) - K * H;
    P = I_KH * Pp * I_KH.transpose() + K * R * K.transpose();
    ASSERT_EQ(imm.step(z), StepStatus::kOk);
    EXPECT_LT((imm.estimate().mean - x).norm(), 1e-10 * x.norm());
    EXPECT_LT((imm.estimate().covariance - P).norm(), 1e-10 * P.norm());
  }
}

// The file keeps each table (a version-3 field: an older reader would run the fixed Q); a mode
// without one stays unscheduled; a Singer mode cannot take one.
TEST(ScheduledNoise, TheFileCarriesTheScheduleAndRefusalsNameTheField) {
  PlainImmSpec spec = schedule_spec_of({mode_spec("cv", MotionKind::kConstantVelocity, 0.05),
                                        mode_spec("ct", MotionKind::kCoordinatedTurn, 0.5, 1e-4)},
                                       MeasurementKind::kPolar);
  spec.modes[1].noise_schedule =
      FuzzyRuleTable({{0.5, 0.8, -2.0, 1.0, 0.7}, {4.0, 0.8, 2.0, 1.0, 6.0}});
  EXPECT_TRUE(spec.has_noise_schedule());
  const testing::TempDir dir;
  const auto path = dir / "scheduled.h5";
  testing::write_model(path, io::kPlainImmKind,
                       [&](io::ModelFileWriter& writer) { io::write_plain_imm(writer, spec); });
  const io::ModelFileReader reader(path, io::kPlainImmKind);
  EXPECT_EQ(reader.schema_version(), 3);
  const PlainImmSpec read = io::read_plain_imm(reader);
  EXPECT_FALSE(read.modes[0].noise_schedule.has_value());
  ASSERT_TRUE(read.modes[1].noise_schedule.has_value());
  ASSERT_EQ(read.modes[1].noise_schedule->size(), 2U);
  EXPECT_EQ(read.modes[1].noise_schedule->rules()[1].w, 6.0);
  EXPECT_EQ(read.modes[1].noise_schedule->rules()[0].c2, -2.0);

  PlainImmSpec singer =
      schedule_spec_of({mode_spec("s", MotionKind::kSinger, 0.0)}, MeasurementKind::kCartesian);
  singer.modes[0].singer_sigma = 1.0;
  singer.modes[0].noise_schedule = constant_table(1.0);
  try {
    singer.validate();
    FAIL() << "a scheduled Singer mode was accepted";
  } catch (const InvalidParameter& error) {
    EXPECT_EQ(error.field(), "modes[0].noise_schedule");
  }
  // The CV bank's kernel has a fixed Q: it refuses, naming the field.
  PlainImmSpec cv = schedule_spec_of({mode_spec("cv", MotionKind::kConstantVelocity, 0.05)},
                                     MeasurementKind::kCartesian);
  cv.modes[0].noise_schedule = constant_table(1.0);
  try {
    const TrackBank bank(cv, 4);
    FAIL() << "the CV bank accepted a scheduled mode";
  } catch (const InvalidParameter& error) {
    EXPECT_EQ(error.field(), "modes[0].noise_schedule");
  }
}

}  // namespace
}  // namespace imm
