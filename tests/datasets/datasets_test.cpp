#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/maneuver_scenario.hpp"
#include "imm/datasets/random.hpp"
#include "imm/datasets/range_sensor.hpp"
#include "imm/datasets/range_sensor_file.hpp"
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
  s.measurement.sigma = Eigen::Vector2d(1e-9, 1e-9);  // the smallest σ a scenario takes
  const ScenarioData data = simulate(s);
  EXPECT_NEAR(data.measurements[0](0, 0), 5000.0, 1e-6);
  EXPECT_NEAR(data.measurements[0](0, 1), std::atan2(3000.0, 4000.0), 1e-7);
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

// --- Seed 002: the range sensor and the cut-in ------------------------------------------------

TEST(RangeDistortion, CompressesTheRangeBeyondTheKnee) {
  const RangeDistortion d;  // knee 40, L 30
  EXPECT_EQ(d.apply(Eigen::Vector2d(1.5, 25.0)), Eigen::Vector2d(1.5, 25.0));
  EXPECT_EQ(d.apply(Eigen::Vector2d(-2.0, 40.0)), Eigen::Vector2d(-2.0, 40.0));
  const Eigen::Vector2d far = d.apply(Eigen::Vector2d(2.0, 70.0));
  EXPECT_NEAR(far(1), 40.0 + 30.0 * std::tanh(1.0), 1e-12);
  EXPECT_NEAR(far(0), 2.0 * far(1) / 70.0, 1e-12);  // ξ by the same ratio
  // The hard sensor: slope sech²(2) ≈ 0.0707 at 60 m, saturating at knee + L.
  RangeDistortion hard;
  hard.softness = 10.0;
  const double h = 1e-5;
  const double slope = (hard.apply(Eigen::Vector2d(0.0, 60.0 + h))(1) -
                        hard.apply(Eigen::Vector2d(0.0, 60.0 - h))(1)) /
                       (2.0 * h);
  EXPECT_NEAR(slope, 1.0 / std::pow(std::cosh(2.0), 2), 1e-8);
  EXPECT_LT(hard.apply(Eigen::Vector2d(0.0, 1e4))(1), 50.0 + 1e-9);
  // Continuous with slope 1 at the knee.
  EXPECT_NEAR(d.apply(Eigen::Vector2d(0.0, 40.0 + 1e-7))(1), 40.0 + 1e-7, 1e-12);
}

TEST(RangeSensorData, SamplesTheBoxWithTheConfiguredNoise) {
  RangeSensorDataConfig config;
  config.samples = 4000;
  config.seed = 5;
  const RangeSensorData data = simulate_range_sensor(config);
  ASSERT_EQ(data.positions.rows(), 4000);
  EXPECT_GE(data.positions.col(0).minCoeff(), -6.0);
  EXPECT_LE(data.positions.col(0).maxCoeff(), 6.0);
  EXPECT_GE(data.positions.col(1).minCoeff(), 1.0);
  EXPECT_LE(data.positions.col(1).maxCoeff(), 100.0);
  Eigen::MatrixXd noise(4000, 2);
  for (Eigen::Index q = 0; q < 4000; ++q) {
    noise.row(q) = data.outputs.row(q) -
                   config.distortion.apply(data.positions.row(q).transpose()).transpose();
  }
  for (int i = 0; i < 2; ++i) {
    EXPECT_NEAR(noise.col(i).mean(), 0.0, 4.0 * 0.05 / std::sqrt(4000.0));
    EXPECT_NEAR(std::sqrt(noise.col(i).squaredNorm() / 4000.0), 0.05, 0.003);
  }
  EXPECT_EQ(simulate_range_sensor(config).outputs, data.outputs);
  config.seed = 6;
  EXPECT_NE(simulate_range_sensor(config).outputs, data.outputs);
}

TEST(CutIn, TruthFollowsTheSeedsManeuver) {
  CutInScenario s;
  s.runs = 1;
  const CutInData data = simulate_cut_in(s);
  ASSERT_EQ(data.truth.rows(), 200);
  auto row = [&](double t) {
    return data.truth.row(static_cast<Eigen::Index>(std::lround(t / 0.1)));
  };
  EXPECT_DOUBLE_EQ(row(0.0)(0), 3.5);  // beside the host, lane 1
  EXPECT_DOUBLE_EQ(row(0.0)(3), 0.0);
  EXPECT_NEAR(row(4.0)(0), 0.0, 1e-12);  // in front of the host after the cut-in
  EXPECT_NEAR(row(10.0)(0), 0.0, 1e-12);
  EXPECT_NEAR(row(19.9)(0), 3.5, 1e-12);  // back in lane 1
  EXPECT_NEAR(row(2.5)(0), 1.75, 1e-12);  // half-way through the half-cosine
  for (Eigen::Index k = 0; k < 200; ++k) {
    EXPECT_NEAR(data.truth(k, 3), 3.0 * 0.1 * static_cast<double>(k), 1e-12);  // 33 − 30 m/s
    EXPECT_EQ(data.truth(k, 4), 3.0);
  }
  // Velocity and acceleration are the derivatives of the position (central differences; the
  // acceleration jumps at the ends of each move, t = 1, 4, 14, 18 s).
  for (Eigen::Index k = 1; k + 1 < 200; ++k) {
    if (k == 10 || k == 40 || k == 140 || k == 180) continue;
    const double v = (data.truth(k + 1, 0) - data.truth(k - 1, 0)) / 0.2;
    const double a = (data.truth(k + 1, 1) - data.truth(k - 1, 1)) / 0.2;
    EXPECT_NEAR(data.truth(k, 1), v, 0.02) << k;
    EXPECT_NEAR(data.truth(k, 2), a, 0.05) << k;
  }
  // Peak lateral speed of a half-cosine over 3 s: π·3.5/(2·3).
  EXPECT_NEAR(data.truth.col(1).cwiseAbs().maxCoeff(), M_PI * 3.5 / 6.0, 1e-3);
}

TEST(CutIn, PlotsAreTheDistortedPositionPlusNoiseOfCovarianceR) {
  CutInScenario s;
  s.runs = 300;
  s.measurement_covariance << 0.25, 0.1, 0.1, 1.0;
  const CutInData data = simulate_cut_in(s);
  Eigen::Matrix2d sum = Eigen::Matrix2d::Zero();
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  const Eigen::Index k = 150;
  const Eigen::Vector2d clean =
      s.distortion.apply(Eigen::Vector2d(data.truth(k, 0), data.truth(k, 3)));
  for (const auto& z : data.measurements) {
    const Eigen::Vector2d e = z.row(k).transpose() - clean;
    mean += e / 300.0;
    sum += e * e.transpose() / 300.0;
  }
  EXPECT_NEAR(mean(0), 0.0, 0.15);
  EXPECT_NEAR(mean(1), 0.0, 0.25);
  EXPECT_NEAR(sum(0, 0), 0.25, 0.07);
  EXPECT_NEAR(sum(1, 1), 1.0, 0.25);
  EXPECT_NEAR(sum(0, 1), 0.1, 0.07);
  // Run r depends only on (seed, r).
  s.runs = 3;
  EXPECT_EQ(simulate_cut_in(s).measurements[2], data.measurements[2]);
}

TEST(CutIn, ValidationNamesTheField) {
  CutInScenario s;
  s.return_start = 2.0;
  try {
    s.validate();
    ADD_FAILURE() << "accepted";
  } catch (const InvalidParameter& error) {
    EXPECT_EQ(error.field(), "cut_in");
  }
  s = CutInScenario{};
  s.distortion.softness = 0.0;
  EXPECT_THROW(s.validate(), InvalidParameter);
}

TEST(RangeSensorFile, RoundTripAndAlteredDataAreDetected) {
  const testing::TempDir dir;
  RangeSensorDataConfig config;
  config.samples = 300;
  config.distortion.softness = 12.0;
  const RangeSensorData data = simulate_range_sensor(config);
  const std::string written =
      write_range_sensor_dataset(dir / "r.h5", config, data, "seed = 1\n", "v1");
  const RangeSensorDataset back = read_range_sensor_dataset(dir / "r.h5");
  EXPECT_EQ(back.digest, written);
  EXPECT_EQ(back.digest, digest(data));
  EXPECT_EQ(back.data.positions, data.positions);
  EXPECT_EQ(back.data.outputs, data.outputs);
  EXPECT_EQ(back.distortion.softness, 12.0);
  EXPECT_EQ(back.noise_sigma, 0.05);

  // A file whose arrays no longer match its digest (sealed with a valid checksum, so only the
  // digest can tell).
  RangeSensorData altered = data;
  altered.outputs(17, 1) += 0.001;
  EXPECT_NE(digest(altered), written);
  {
    io::ContainerWriter writer(dir / "altered.h5", kDatasetFormat);
    writer.set_attribute("/", "format", std::string(kDatasetFormat));
    writer.set_attribute("/", "schema_version", std::int64_t{kDatasetSchemaVersion});
    writer.set_attribute("/", "dataset_kind", std::string("range_sensor"));
    writer.set_attribute("/", "digest", written);
    writer.write("/positions", altered.positions);
    writer.write("/outputs", altered.outputs);
    writer.set_attribute("/parameters", "knee", 40.0);
    writer.set_attribute("/parameters", "softness", 12.0);
    writer.set_attribute("/parameters", "noise_sigma", 0.05);
    writer.commit();
  }
  try {
    (void)read_range_sensor_dataset(dir / "altered.h5");
    ADD_FAILURE() << "accepted";
  } catch (const io::FileError& error) {
    EXPECT_EQ(error.field(), "/@digest") << error.what();
  }
  // The cut-in data set: runs × steps × 2 plots and the truth, back as written.
  CutInScenario scenario;
  scenario.runs = 3;
  scenario.steps = 50;
  scenario.measurement_covariance = Eigen::Vector2d(0.25, 1.0).asDiagonal();
  const CutInData cut_in = simulate_cut_in(scenario);
  const std::string cut_in_digest = write_cut_in_dataset(dir / "c.h5", scenario, cut_in, "", "v1");
  const CutInDataset cut_in_back = read_cut_in_dataset(dir / "c.h5");
  EXPECT_EQ(cut_in_back.digest, cut_in_digest);
  EXPECT_EQ(cut_in_back.data.truth, cut_in.truth);
  ASSERT_EQ(cut_in_back.data.measurements.size(), 3u);
  for (std::size_t r = 0; r < 3; ++r) {
    EXPECT_EQ(cut_in_back.data.measurements[r], cut_in.measurements[r]);
  }
  EXPECT_EQ(cut_in_back.r_sigma, Eigen::Vector2d(0.5, 1.0));
  EXPECT_THROW((void)read_cut_in_dataset(dir / "r.h5"), io::FileError);
  // A scenario data set is not a range-sensor data set.
  ManeuverScenario m = seed000_scenario();
  m.runs = 1;
  write_scenario_dataset(dir / "m.h5", m, simulate(m), "", "v1");
  EXPECT_THROW((void)read_range_sensor_dataset(dir / "m.h5"), io::FileError);
}

}  // namespace
}  // namespace imm::datasets
