// SPDX-License-Identifier: Apache-2.0
// The classical CV/CA/CT IMM's tuner: on tracks drawn from a planted coordinated-turn model it
// recovers the planted noise intensities, with truth (ζ_p + ζ_v) and from the plots alone (the
// predictive likelihood); on tracks that switch between straight flight and turns it prefers the
// mode set with a turn mode; the score is the same at any thread count; bad configs are refused
// naming the key.

#include "imm/trainer/classical/classical_imm.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <numbers>
#include <random>

#include "imm/datasets/regime_file.hpp"
#include "imm/models/motion/coordinated_turn.hpp"
#include "imm/support/config.hpp"
#include "testing/planted_scan.hpp"
#include "testing/temp_dir.hpp"

namespace imm::trainer::classical {
namespace {

constexpr double kT = 2.0;
constexpr double kSigma = 20.0;

// The regime gives the search its scales (speeds to 200 m/s, turns to 3°/s: a ≈ 10.5 m/s²) and the
// plots' σ; the tracks themselves are drawn below from the planted model.
datasets::Regime planted_regime() {
  return datasets::parse_regime(R"(name = "planted"
units = "m"
sample_period = 2.0
scans = 120
process_noise_sigma = 0.0
[sensor]
kind = "cartesian"
sigma = [20.0, 20.0]
[start]
range = [10000.0, 20000.0]
bearing_deg = [0.0, 360.0]
heading = "inbound"
heading_offset_deg = [-30.0, 30.0]
speed = [100.0, 200.0]
[[maneuvers]]
kind = "turn"
probability = 1.0
duration = [20.0, 40.0]
rate_deg = [1.0, 3.0]
[splits]
training = 12
validation = 4
test = 10
seed = 3
)",
                                "planted")
      .regime;
}

// Tracks whose truth follows the CT model with process noise Q(q_a, q_ω), seen with σ = 20 m.
// With `switching`, the turn rate is forced to 0 (straight flight) or back to a drawn turn with
// probability `leave` per scan.
datasets::TrackSet planted_tracks(double q_a, double q_omega, int tracks, int scans,
                                  std::uint64_t seed, bool truth = true, bool switching = false,
                                  double leave = 0.05) {
  datasets::TrackSet set;
  set.regime = "planted";
  set.split = datasets::Split::kTraining;
  set.sample_period = kT;
  set.scans = scans;
  set.has_truth = truth;
  const SquareMatrix<5> Q = coordinated_turn_noise(kT, q_a, q_omega);
  const Eigen::LLT<SquareMatrix<5>> root(Q + 1e-20 * SquareMatrix<5>::Identity());
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (int t = 0; t < tracks; ++t) {
    datasets::Track track;
    track.truth = Eigen::MatrixXd::Zero(scans, 6);
    track.plots.resize(scans, 2);
    Vector<5> x;
    const double heading = 2.0 * std::numbers::pi * uniform(rng);
    const double speed = 100.0 + 100.0 * uniform(rng);
    x << 0.0, speed * std::cos(heading), 0.0, speed * std::sin(heading),
        switching ? 0.0 : 0.03 * (uniform(rng) - 0.5);
    bool turning = false;
    for (int k = 0; k < scans; ++k) {
      if (switching && uniform(rng) < leave) {
        // Straight, or a sustained turn of 2–3.4 °/s either way.
        turning = !turning;
        x(4) = turning ? (0.035 + 0.025 * uniform(rng)) * (uniform(rng) < 0.5 ? -1.0 : 1.0) : 0.0;
      }
      Vector<5> w;
      for (int i = 0; i < 5; ++i) w(i) = normal(rng);
      x = coordinated_turn_step(x, kT) + root.matrixL() * w;
      testing::record_scan(track, k, x.head<4>(), kSigma, rng, normal);
    }
    if (!truth) track.truth.setConstant(std::nan(""));
    set.tracks.push_back(std::move(track));
  }
  return set;
}

// The planted intensities back, within half a decade for the linear acceleration and a decade for
// the turn rate's (whose effect on 120 scans of 20 m plots is small), with truth and without.
TEST(ClassicalImm, TheTunerRecoversPlantedIntensities) {
  const double q_a = 0.5, q_omega = 1e-6;
  ClassicalImmConfig config;
  config.regime = planted_regime();
  config.mode_sets = {{MotionKind::kCoordinatedTurn}};
  config.grid_points = 3;
  config.polish_evaluations = 100;
  for (const bool truth : {true, false}) {
    SCOPED_TRACE(truth ? "with truth" : "plots alone");
    const datasets::TrackSet training = planted_tracks(q_a, q_omega, 12, 120, 41, truth);
    const TunedClassicalImm tuned = tune_classical_imm(config, training);
    ASSERT_EQ(tuned.spec.modes.size(), 1U);
    EXPECT_EQ(tuned.criterion, truth ? "zeta_p_plus_zeta_v" : "excess_nll");
    EXPECT_NEAR(std::log10(tuned.spec.modes[0].process_noise), std::log10(q_a), 0.5);
    EXPECT_NEAR(std::log10(tuned.spec.modes[0].turn_noise), std::log10(q_omega), 1.0);
    // The planted model itself scores no better than what the tuner found (within rounding).
    PlainImmSpec planted = tuned.spec;
    planted.modes[0].process_noise = q_a;
    planted.modes[0].turn_noise = q_omega;
    EXPECT_LE(tuned.score.objective, score_classical(planted, training).objective + 1e-3);
  }
}

// Tracks that alternate between straight flight and sustained turns of 2–3.4 °/s (about 20 scans
// each): the CV + CT set beats the CV + CA set on them — a CA mode's acceleration does not rotate
// with the velocity — and the tuner keeps it; it records every set it tried.
TEST(ClassicalImm, TheTunerChoosesTheModesThatFitTheTracks) {
  ClassicalImmConfig config;
  config.regime = planted_regime();
  config.mode_sets = {{MotionKind::kConstantVelocity, MotionKind::kConstantAcceleration},
                      {MotionKind::kConstantVelocity, MotionKind::kCoordinatedTurn}};
  config.grid_points = 3;
  config.polish_evaluations = 60;
  const datasets::TrackSet training = planted_tracks(0.05, 1e-9, 10, 120, 7, true, true, 0.05);
  const TunedClassicalImm tuned = tune_classical_imm(config, training);
  ASSERT_EQ(tuned.tried.size(), 2U);
  EXPECT_EQ(to_string(tuned.modes), "cv,ct");
  EXPECT_LT(tuned.tried[1].second, tuned.tried[0].second);
  EXPECT_GT(tuned.spec.transition(0, 0), 0.5);
}

// Per-track terms summed in track order: the same score to the bit at one and two threads.
TEST(ClassicalImm, TheScoreIsTheSameAtAnyThreadCount) {
  const datasets::TrackSet set = planted_tracks(0.5, 1e-6, 8, 80, 3);
  const PlainImmSpec spec =
      classical_spec(planted_regime(),
                     {MotionKind::kConstantVelocity, MotionKind::kConstantAcceleration,
                      MotionKind::kCoordinatedTurn},
                     {0.0, -1.0, -1.0, -6.0, -2.0});
  omp_set_num_threads(1);
  const ClassicalScore one = score_classical(spec, set);
  omp_set_num_threads(2);
  const ClassicalScore two = score_classical(spec, set);
  EXPECT_EQ(one.objective, two.objective);
  EXPECT_EQ(one.excess_nll, two.excess_nll);
  EXPECT_TRUE(std::isfinite(one.objective));
  EXPECT_GT(one.zeta_p, 0.0);
  EXPECT_LT(one.zeta_p, 1.0);  // a tracker beats its plots
}

// Configs: unknown modes, Singer, repeats and absurd budgets are refused naming the key.
TEST(ClassicalImm, BadConfigsAreRefusedNamingTheKey) {
  const testing::TempDir dir;
  const auto refused = [&](const std::string& table, const std::string& key) {
    testing::write_text(
        dir / "c.toml",
        "regime = \"configs/regimes/agile_air.toml\"\n[classical]\n" + table + "\n");
    try {
      (void)load_classical_config(dir / "c.toml");
      ADD_FAILURE() << table;
    } catch (const support::ConfigError& error) {
      EXPECT_NE(std::string(error.what()).find(key), std::string::npos) << error.what();
    }
  };
  refused("mode_sets = [\"cv,warp\"]", "mode_sets");
  refused("mode_sets = [\"cv,singer\"]", "mode_sets");
  refused("mode_sets = [\"cv,cv\"]", "mode_sets");
  refused("grid_points = 1", "grid_points");
  refused("polish_evaluations = 100000", "polish_evaluations");
  refused("polish_evaluations = -5", "polish_evaluations");  // read as 0 before
  testing::write_text(dir / "ok.toml",
                      "regime = \"configs/regimes/agile_air.toml\"\n[classical]\nmode_sets = "
                      "[\"cv, ct\"]\n");
  EXPECT_TRUE(is_classical_config(dir / "ok.toml"));
  const ClassicalImmConfig config = load_classical_config(dir / "ok.toml");
  ASSERT_EQ(config.mode_sets.size(), 1U);
  EXPECT_EQ(to_string(config.mode_sets[0]), "cv,ct");
}

}  // namespace
}  // namespace imm::trainer::classical
