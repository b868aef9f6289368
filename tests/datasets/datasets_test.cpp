#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/maneuver_scenario.hpp"
#include "imm/datasets/random.hpp"
#include "imm/datasets/sha256.hpp"
#include "imm/io/container_file.hpp"
#include "imm/io/file_error.hpp"
#include "testing/temp_dir.hpp"

namespace imm::datasets {
namespace {

TEST(Sha256, MatchesFipsTestVectors) {
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  Sha256 million;
  const std::string block(1000, 'a');
  for (int i = 0; i < 1000; ++i) million.update(block);
  EXPECT_EQ(million.hex_digest(),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Rng, EngineIsTheStandardMersenneTwister) {
  // The standard fixes mt19937_64's 10000th output; our uniform() consumes one output per call.
  std::mt19937_64 reference(5489u);
  Rng rng(5489u);
  for (int i = 0; i < 9999; ++i) (void)reference();
  EXPECT_EQ(reference(), 9981545732273789042ULL);
  std::mt19937_64 again(5489u);
  EXPECT_EQ(rng.uniform(), static_cast<double>(again() >> 11U) * 0x1.0p-53);
}

TEST(Rng, NormalHasUnitMomentsAndStreamsAreDistinct) {
  Rng rng(derive_seed(42, 0));
  double sum = 0.0, squares = 0.0;
  constexpr int kSamples = 400'000;
  for (int i = 0; i < kSamples; ++i) {
    const double x = rng.normal();
    sum += x;
    squares += x * x;
  }
  // 6-sigma bands of the sample mean and variance.
  EXPECT_NEAR(sum / kSamples, 0.0, 6.0 / std::sqrt(kSamples));
  EXPECT_NEAR(squares / kSamples, 1.0, 6.0 * std::sqrt(2.0 / kSamples));
  EXPECT_NE(derive_seed(42, 0), derive_seed(42, 1));
  EXPECT_NE(derive_seed(42, 0), derive_seed(43, 0));
}

TEST(ManeuverScenario, NoiseFreeTruthFollowsTheKinematics) {
  ManeuverScenario s;
  s.steps = 30;
  s.sample_period = 0.5;
  s.initial_position = Eigen::Vector2d(1.0, 2.0);
  s.initial_velocity = Eigen::Vector2d(0.3, -0.1);
  s.maneuvers = {{10, 20, Eigen::Vector2d(0.2, 0.4)}};
  s.process_noise_sigma = 0.0;
  const ScenarioData data = simulate(s);
  const Eigen::MatrixXd& truth = data.truth.front();
  // By hand: x(k) for k ≥ 20 = x0 + v0 t + a·τ·(t − 10T − τ/2), τ = 10T = 5 s of acceleration.
  const double T = 0.5, tau = 5.0;
  for (Eigen::Index k : {0, 10, 15, 20, 29}) {
    const double t = static_cast<double>(k) * T;
    const double accel_time = std::clamp(t - 10 * T, 0.0, tau);
    for (Eigen::Index axis = 0; axis < 2; ++axis) {
      const double a = s.maneuvers[0].acceleration(axis);
      const double expected_v = s.initial_velocity(axis) + a * accel_time;
      const double expected_p = s.initial_position(axis) + s.initial_velocity(axis) * t +
                                0.5 * a * accel_time * accel_time +
                                a * accel_time * std::max(0.0, t - 10 * T - tau);
      EXPECT_NEAR(truth(k, 2 * axis), expected_p, 1e-12) << "k=" << k;
      EXPECT_NEAR(truth(k, 2 * axis + 1), expected_v, 1e-12) << "k=" << k;
    }
  }
}

TEST(ManeuverScenario, Seed003ZigzagIsPerpendicularAndReturnsToThePath) {
  datasets::ManeuverScenario s = datasets::seed003_scenario();
  s.process_noise_sigma = 0.0;
  s.runs = 1;
  const datasets::ScenarioData data = datasets::simulate(s);
  const Eigen::MatrixXd& x = data.truth.front();
  const Eigen::Vector2d heading = -Eigen::Vector2d(300e3, 200e3).normalized();
  const Eigen::Vector2d lateral(-heading.y(), heading.x());
  auto position = [&](int k) { return Eigen::Vector2d(x(k, 0), x(k, 2)); };
  auto velocity = [&](int k) { return Eigen::Vector2d(x(k, 1), x(k, 3)); };
  // Straight at 450 m/s toward the observer until scan 136, and again from scan 264 on, back on
  // the original line (every zigzag period returns the lateral velocity and offset to zero).
  for (int k : {0, 136, 264, 399}) {
    EXPECT_NEAR((velocity(k) - 450.0 * heading).norm(), 0.0, 1e-6) << k;
    EXPECT_NEAR((position(k) - (Eigen::Vector2d(300e3, 200e3) + 450.0 * k * heading)).norm(), 0.0,
                1e-5)
        << k;
  }
  // The accelerations are perpendicular to the path and 30 … 60 m/s²; the first swing peaks at
  // a·quarter² = 30·64 m off the line at scan 152.
  for (int k = 0; k < s.steps; ++k) {
    const Eigen::Vector2d a(data.acceleration_input(k, 0), data.acceleration_input(k, 1));
    EXPECT_NEAR(a.dot(heading), 0.0, 1e-9);
    const bool inside = k >= 136 && k < 264;
    EXPECT_EQ(a.norm() > 0.0, inside) << k;
    if (inside) {
      EXPECT_TRUE(a.norm() > 29.9 && a.norm() < 60.1) << k;
    }
  }
  EXPECT_NEAR(
      (position(152) - (Eigen::Vector2d(300e3, 200e3) + 450.0 * 152 * heading)).dot(lateral),
      30.0 * 64.0, 1e-6);
  // --accel-scale 10: the seed's literal values.
  EXPECT_NEAR(datasets::seed003_scenario(10.0).maneuvers.back().acceleration.norm(), 600.0, 1e-9);
}

TEST(ManeuverScenario, RunsAreReproducibleAndIndependentOfTheRunCount) {
  ManeuverScenario s = seed000_scenario();
  s.runs = 5;
  const ScenarioData five = simulate(s);
  s.runs = 3;
  const ScenarioData three = simulate(s);
  for (std::size_t r = 0; r < 3; ++r) {
    EXPECT_EQ(five.truth[r], three.truth[r]);
    EXPECT_EQ(five.measurements[r], three.measurements[r]);
  }
  EXPECT_NE(five.measurements[0], five.measurements[1]);
  EXPECT_EQ(digest(simulate(s)), digest(three));
  s.seed = 2;
  EXPECT_NE(digest(simulate(s)), digest(three));
}

TEST(ManeuverScenario, MeasurementNoiseHasTheConfiguredSpread) {
  ManeuverScenario s = seed000_scenario();
  s.runs = 200;
  const ScenarioData data = simulate(s);
  double squares = 0.0;
  int count = 0;
  for (std::size_t r = 0; r < data.truth.size(); ++r) {
    const Eigen::MatrixXd error = data.measurements[r].col(0) - data.truth[r].col(0);
    squares += error.squaredNorm();
    count += static_cast<int>(error.size());
  }
  EXPECT_NEAR(std::sqrt(squares / count), 0.5, 0.5 * 6.0 / std::sqrt(2.0 * count));
}

TEST(ManeuverScenario, PolarMeasurementsAreRangeAndAzimuthFromNorth) {
  ManeuverScenario s;
  s.steps = 3;
  s.initial_position = Eigen::Vector2d(3000.0, 4000.0);
  s.measurement.kind = MeasurementKind::kPolar;
  s.measurement.sigma = Eigen::Vector2d(1e-9, 1e-12);
  const ScenarioData data = simulate(s);
  EXPECT_NEAR(data.measurements[0](0, 0), 5000.0, 1e-6);
  EXPECT_NEAR(data.measurements[0](0, 1), std::atan2(3000.0, 4000.0), 1e-9);
}

TEST(ManeuverScenario, ValidationNamesTheField) {
  ManeuverScenario s = seed000_scenario();
  s.maneuvers[1].end = 500;
  try {
    s.validate();
    FAIL();
  } catch (const InvalidParameter& error) {
    EXPECT_EQ(error.field(), "maneuvers[1].end");
  }
  s = seed000_scenario();
  s.measurement.sigma(1) = 0.0;
  EXPECT_THROW(s.validate(), InvalidParameter);
}

TEST(DatasetFile, RoundTripPreservesEverything) {
  const testing::TempDir dir;
  ManeuverScenario s = seed000_scenario();
  s.runs = 4;
  const ScenarioData data = simulate(s);
  const std::string written = write_scenario_dataset(dir / "d.h5", s, data, "name = \"x\"\n", "v1");
  const ScenarioDataset back = read_scenario_dataset(dir / "d.h5");
  EXPECT_EQ(back.digest, written);
  EXPECT_EQ(back.config_toml, "name = \"x\"\n");
  EXPECT_EQ(back.generator_version, "v1");
  EXPECT_EQ(back.scenario.maneuvers.size(), 3u);
  EXPECT_EQ(back.scenario.maneuvers[1].acceleration, s.maneuvers[1].acceleration);
  EXPECT_EQ(back.scenario.initial_velocity, s.initial_velocity);
  for (std::size_t r = 0; r < 4; ++r) {
    EXPECT_EQ(back.data.truth[r], data.truth[r]);
    EXPECT_EQ(back.data.measurements[r], data.measurements[r]);
  }
}

TEST(DatasetFile, IsNotAModelFileAndViceVersa) {
  const testing::TempDir dir;
  ManeuverScenario s = seed000_scenario();
  s.runs = 1;
  write_scenario_dataset(dir / "d.h5", s, simulate(s), "", "v1");
  io::ContainerWriter other(dir / "m.h5", "immtrain-model");
  other.commit();
  EXPECT_THROW((void)read_scenario_dataset(dir / "m.h5"), io::FileError);
}

}  // namespace
}  // namespace imm::datasets
