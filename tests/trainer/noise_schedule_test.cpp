// SPDX-License-Identifier: Apache-2.0
// Noise schedules learned on a tuned IMM (imm/trainer/classical/noise_schedule.hpp): on tracks
// whose process noise bursts — quiet flight, then stretches of strong random acceleration — a
// fixed-Q CV filter is wrong half the time, and the learned schedule switches on, improves the
// validation tracks and raises Q where the normalized innovation is large (the adaptation a
// tracking engineer would hand-write); with no search budget it stays off and the spec is the base
// itself; the config's [schedule] is checked naming the key.

#include "imm/trainer/classical/noise_schedule.hpp"

#include <gtest/gtest.h>

#include <random>

#include "imm/models/motion/constant_velocity.hpp"
#include "imm/support/config.hpp"
#include "testing/planted_scan.hpp"
#include "testing/temp_dir.hpp"

namespace imm::trainer::classical {
namespace {

constexpr double kSchedulePeriod = 1.0;
constexpr double kScheduleSigma = 10.0;

// CV truth whose acceleration variance per period switches between 0.01 and 100 (m/s²)² every 25
// scans, seen with σ = 10 m.
datasets::TrackSet bursting_tracks(int tracks, std::uint64_t seed) {
  datasets::TrackSet set;
  set.regime = "bursts";
  set.sample_period = kSchedulePeriod;
  set.scans = 150;
  set.has_truth = true;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int t = 0; t < tracks; ++t) {
    datasets::Track track;
    track.truth = Eigen::MatrixXd::Zero(set.scans, 6);
    track.plots.resize(set.scans, 2);
    Eigen::Vector4d x(0.0, 50.0, 0.0, -20.0);
    for (int k = 0; k < set.scans; ++k) {
      const double sigma_a = (k / 25) % 2 == 1 ? 10.0 : 0.1;
      for (const int axis : {0, 2}) {
        const double a = sigma_a * normal(rng);
        x(axis) += x(axis + 1) * kSchedulePeriod + 0.5 * kSchedulePeriod * kSchedulePeriod * a;
        x(axis + 1) += kSchedulePeriod * a;
      }
      testing::record_scan(track, k, x, kScheduleSigma, rng, normal);
    }
    set.tracks.push_back(std::move(track));
  }
  return set;
}

// One CV mode of q = 10 (m/s²)²: far too much in the quiet, too little in a burst.
PlainImmSpec fixed_cv() {
  PlainImmSpec spec;
  spec.sample_period = kSchedulePeriod;
  ModeSpec cv;
  cv.name = "cv";
  cv.process_noise = 10.0;
  spec.modes = {cv};
  spec.transition = Eigen::MatrixXd::Ones(1, 1);
  spec.initial_probabilities = Eigen::VectorXd::Ones(1);
  spec.measurement.covariance = kScheduleSigma * kScheduleSigma * Eigen::Matrix2d::Identity();
  spec.initialization.acceleration_variance = 1.0;
  return spec;
}

TEST(NoiseSchedule, OnBurstingNoiseItSwitchesOnAndRaisesQWhereTheInnovationIsLarge) {
  const datasets::TrackSet training = bursting_tracks(10, 1);
  const datasets::TrackSet validation = bursting_tracks(8, 2);
  const LearnedSchedule learned = learn_noise_schedule(fixed_cv(), training, validation, 300);
  ASSERT_TRUE(learned.on);
  // Beyond a few percent on tracks it never saw.
  EXPECT_LT(learned.validation.objective, 0.97 * learned.validation_base.objective);
  const FuzzyRuleTable& table = *learned.spec.modes[0].noise_schedule;
  // At d = 3.5 (a plot 3.5 σ off) the schedule asks for more noise than at d = 0.75.
  EXPECT_GT(table.process_noise(3.5, 0.0), 2.0 * table.process_noise(0.75, 0.0));
}

TEST(NoiseSchedule, WithoutABudgetItStaysOffAndIsTheBaseItself) {
  const datasets::TrackSet training = bursting_tracks(3, 1);
  const datasets::TrackSet validation = bursting_tracks(3, 2);
  // One evaluation: the identity schedule, which ties the base; a tie keeps the base.
  const LearnedSchedule learned = learn_noise_schedule(fixed_cv(), training, validation, 1);
  EXPECT_FALSE(learned.on);
  EXPECT_FALSE(learned.spec.has_noise_schedule());
  EXPECT_EQ(learned.training.objective, learned.training_base.objective);
  EXPECT_EQ(learned.spec.modes[0].process_noise, 10.0);
}

TEST(NoiseSchedule, TheConfigsScheduleTableIsCheckedNamingTheKey) {
  const testing::TempDir dir;
  const std::string head = "regime = \"configs/regimes/agile_air.toml\"\n[classical]\n";
  testing::write_text(dir / "zero.toml", head + "[schedule]\nevaluations = 0\n");
  try {
    (void)load_classical_config(dir / "zero.toml");
    ADD_FAILURE() << "evaluations = 0 was accepted";
  } catch (const support::ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("schedule.evaluations"), std::string::npos)
        << error.what();
  }
  testing::write_text(dir / "ok.toml", head + "[schedule]\nevaluations = 25\n");
  EXPECT_EQ(load_classical_config(dir / "ok.toml").schedule_evaluations, 25);
  testing::write_text(dir / "none.toml", head);
  EXPECT_FALSE(load_classical_config(dir / "none.toml").schedule_evaluations.has_value());
}

}  // namespace
}  // namespace imm::trainer::classical
