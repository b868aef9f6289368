// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>

#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/random.hpp"
#include "imm/datasets/range_sensor.hpp"
#include "imm/datasets/range_sensor_file.hpp"
#include "imm/datasets/regime.hpp"
#include "imm/datasets/sampled_sensor.hpp"
#include "imm/datasets/sha256.hpp"
#include "imm/datasets/track.hpp"
#include "imm/io/container_file.hpp"
#include "imm/io/file_error.hpp"
#include "testing/refused_field.hpp"
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

// A regime built in code: Cartesian σ 0.5, no noise unless asked, one scripted case.
Regime scripted_regime(std::vector<ScriptedSegment> segments, double T = 1.0, int scans = 60) {
  Regime r;
  r.name = "test";
  r.units = Units::kKilometres;
  r.sample_period = T;
  r.scans = scans;
  r.sensor.noise.sigma = Eigen::Vector2d(0.5, 0.5);
  r.start.fixed = true;
  r.start.position = Eigen::Vector2d(1.0, 2.0);
  r.start.velocity = Eigen::Vector2d(0.3, -0.1);
  r.cases.push_back({"only", std::nullopt, std::nullopt, std::move(segments)});
  r.validate();
  return r;
}

ScriptedSegment ca(double start, double end, Eigen::Vector2d a) {
  ScriptedSegment s;
  s.kind = SegmentKind::kConstantAcceleration;
  s.start = start;
  s.end = end;
  s.acceleration = a;
  return s;
}

// The noise-free truth of a constant acceleration, by hand: for t after the segment
// x = x0 + v0 t + a τ (t − t_a − τ/2), τ the accelerated time.
TEST(Track, NoiseFreeTruthFollowsTheKinematics) {
  const double T = 0.5;
  const Regime r = scripted_regime({ca(5.0, 10.0, Eigen::Vector2d(0.2, 0.4))}, T, 30);
  Regime quiet = r;
  quiet.sensor.noise.sigma = Eigen::Vector2d(1e-9, 1e-9);
  const Track track = draw_track(quiet, Split::kTest, 0, 1);
  const double tau = 5.0;
  for (Eigen::Index k : {0, 10, 15, 20, 29}) {
    const double t = static_cast<double>(k) * T;
    const double accel_time = std::clamp(t - 5.0, 0.0, tau);
    for (Eigen::Index axis = 0; axis < 2; ++axis) {
      const double a = Eigen::Vector2d(0.2, 0.4)(axis);
      const double v0 = r.start.velocity(axis), x0 = r.start.position(axis);
      const double expected_v = v0 + a * accel_time;
      const double expected_p = x0 + v0 * t + 0.5 * a * accel_time * accel_time +
                                a * accel_time * std::max(0.0, t - 10.0);
      EXPECT_NEAR(track.truth(k, 3 * axis), expected_p, 1e-12) << "k=" << k;
      EXPECT_NEAR(track.truth(k, 3 * axis + 1), expected_v, 1e-12) << "k=" << k;
      // The commanded acceleration over the transition that starts at k.
      EXPECT_EQ(track.truth(k, 3 * axis + 2), k >= 10 && k < 20 ? a : 0.0) << "k=" << k;
    }
    EXPECT_EQ(track.maneuvering[static_cast<std::size_t>(k)], k >= 10 && k < 20);
    EXPECT_NEAR(track.plots(k, 0), track.truth(k, 0), 1e-7);
  }
}

TEST(Track, ZigzagIsPerpendicularAndReturnsToThePath) {
  ScriptedSegment zigzag;
  zigzag.kind = SegmentKind::kZigzag;
  zigzag.start = 10.0;
  zigzag.quarter = 4.0;
  zigzag.amplitudes = {30.0, 60.0};
  Regime r = scripted_regime({zigzag}, 1.0, 60);
  r.cases[0].start = Start{};
  r.cases[0].start->fixed = true;
  r.cases[0].start->position = Eigen::Vector2d(3e5, 2e5);
  r.cases[0].start->velocity = -450.0 * Eigen::Vector2d(3e5, 2e5).normalized();
  const Track track = draw_track(r, Split::kTest, 0, 1);
  const Eigen::Vector2d heading = -Eigen::Vector2d(3e5, 2e5).normalized();
  const Eigen::Vector2d lateral(-heading.y(), heading.x());
  for (int k : {0, 10, 42, 59}) {  // before, and after the 32 transitions of the zigzag
    EXPECT_NEAR((velocity_at(track, k) - 450.0 * heading).norm(), 0.0, 1e-9) << k;
    EXPECT_NEAR((position_at(track, k) - (Eigen::Vector2d(3e5, 2e5) + 450.0 * k * heading)).norm(),
                0.0, 1e-6)
        << k;
  }
  for (int k = 0; k < 60; ++k) {
    const Eigen::Vector2d a = acceleration_at(track, k);
    EXPECT_NEAR(a.dot(heading), 0.0, 1e-9);
    EXPECT_EQ(a.norm() > 0.0, k >= 10 && k < 42) << k;
  }
  // First swing: +a for a quarter to the left, peak a·quarter² off the line after two quarters.
  EXPECT_NEAR(acceleration_at(track, 10).dot(lateral), 30.0, 1e-9);
  EXPECT_NEAR(
      (position_at(track, 18) - (Eigen::Vector2d(3e5, 2e5) + 450.0 * 18 * heading)).dot(lateral),
      30.0 * 16.0, 1e-6);
  EXPECT_NEAR(acceleration_at(track, 26).dot(lateral), -60.0, 1e-9);  // second period, other side
}

Regime random_regime() {
  Regime r;
  r.name = "random";
  r.sample_period = 1.0;
  r.scans = 80;
  r.process_noise_sigma = 0.1;
  r.sensor.noise.sigma = Eigen::Vector2d(10.0, 10.0);
  r.start.range = {1e3, 5e3};
  r.start.bearing = {0.0, 6.0};
  r.start.speed = {50.0, 100.0};
  r.start.heading = {0.0, 6.0};
  MenuEntry cv;
  cv.probability = 0.4;
  cv.duration = {5.0, 15.0};
  MenuEntry turn;
  turn.kind = SegmentKind::kTurn;
  turn.probability = 0.3;
  turn.duration = {5.0, 10.0};
  turn.rate = {0.02, 0.05};
  MenuEntry accelerate;
  accelerate.kind = SegmentKind::kConstantAcceleration;
  accelerate.probability = 0.3;
  accelerate.duration = {3.0, 8.0};
  accelerate.magnitude = {1.0, 10.0, true};
  accelerate.direction = Direction::kLateral;
  r.menu = {cv, turn, accelerate};
  r.validate();
  return r;
}

TEST(Track, DrawsAreReproduciblePerSeedAndTrackAndSplitsAreDisjoint) {
  const Regime r = random_regime();
  const TrackSet five = draw_split(r, Split::kTraining, 0, 5);
  const TrackSet three = draw_split(r, Split::kTraining, 0, 3);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(five.tracks[i].truth, three.tracks[i].truth);
    EXPECT_EQ(five.tracks[i].plots, three.tracks[i].plots);
  }
  EXPECT_NE(five.tracks[0].truth, five.tracks[1].truth);  // a random start and program each
  // The splits never share a track seed (the test split at the regime's own seed included).
  std::set<std::uint64_t> seeds;
  int count = 0;
  for (Split split : {Split::kTraining, Split::kValidation, Split::kTest}) {
    for (int i = 0; i < 500; ++i, ++count) seeds.insert(track_seed(r, split, i, r.splits.seed));
  }
  EXPECT_EQ(static_cast<int>(seeds.size()), count);
  EXPECT_NE(draw_split(r, Split::kTest, 1, 2).digest(), draw_split(r, Split::kTest, 2, 2).digest());
  EXPECT_EQ(draw_split(r, Split::kTest, 1, 2).digest(), draw_split(r, Split::kTest, 1, 2).digest());
}

// A draw holds no more tracks than a split may (10⁶): a count beyond it (imm-data --count 2e9 ran
// out of memory) is refused naming it, before anything is drawn.
TEST(Track, ADrawOfMoreTracksThanASplitHoldsIsRefused) {
  const Regime r = random_regime();
  EXPECT_EQ(
      testing::refused_field_of([&] { (void)draw_split(r, Split::kTest, 1, kMaxSplitTracks + 1); }),
      "count");
  EXPECT_EQ(draw_split(r, Split::kTest, 1, 1).tracks.size(), 1U);
}

TEST(Track, RandomSegmentsStayWithinTheirMenu) {
  const Regime r = random_regime();
  for (const Track& t : draw_split(r, Split::kTraining, 0, 20).tracks) {
    const double speed0 = velocity_at(t, 0).norm();
    EXPECT_TRUE(speed0 >= 45.0 && speed0 <= 105.0) << speed0;  // [50, 100] plus one noisy step
    for (Eigen::Index k = 0; k < t.truth.rows(); ++k) {
      const Eigen::Vector2d a = acceleration_at(t, k), v = velocity_at(t, k);
      if (a.norm() == 0.0) continue;
      // A turn's centripetal acceleration ω·|v| ≤ 0.05·|v|, or a lateral 1–10 m/s² (taken
      // against the noise-free velocity, so nearly perpendicular to the noisy one).
      EXPECT_LE(a.norm(), std::max(10.0 + 1e-9, 0.05 * v.norm() + 1e-9)) << k;
    }
  }
}

TEST(Track, MeasurementNoiseHasTheConfiguredSpread) {
  Regime r = random_regime();
  r.sensor.noise.correlation = 0.6;
  double sxx = 0.0, syy = 0.0, sxy = 0.0;
  long count = 0;
  for (const Track& t : draw_split(r, Split::kTest, 3, 100).tracks) {
    for (Eigen::Index k = 0; k < t.plots.rows(); ++k) {
      const Eigen::Vector2d e = t.plots.row(k).transpose() - position_at(t, k);
      sxx += e(0) * e(0), syy += e(1) * e(1), sxy += e(0) * e(1);
      ++count;
    }
  }
  const double n = static_cast<double>(count);
  EXPECT_NEAR(std::sqrt(sxx / n), 10.0, 10.0 * 6.0 / std::sqrt(2.0 * n));
  EXPECT_NEAR(std::sqrt(syy / n), 10.0, 10.0 * 6.0 / std::sqrt(2.0 * n));
  EXPECT_NEAR(sxy / n / 100.0, 0.6, 6.0 / std::sqrt(n));
}

TEST(Track, PolarPlotsAreRangeAndAzimuthFromNorthOfTheSensor) {
  Regime r = scripted_regime({}, 1.0, 3);
  r.sensor.kind = SensorKind::kPolar;
  r.sensor.noise.sigma = Eigen::Vector2d(1e-9, 1e-9);
  r.sensor.position = Eigen::Vector2d(1000.0, -500.0);
  r.cases[0].start = Start{};
  r.cases[0].start->fixed = true;
  r.cases[0].start->position = Eigen::Vector2d(4000.0, 3500.0);
  const Track track = draw_track(r, Split::kTest, 0, 1);
  EXPECT_NEAR(track.plots(0, 0), 5000.0, 1e-6);
  EXPECT_NEAR(track.plots(0, 1), std::atan2(3000.0, 4000.0), 1e-7);
}

// Seed 002's cut-in as lane changes: the half-cosine shape, by hand.
TEST(Track, LaneChangesFollowTheHalfCosine) {
  ScriptedSegment in, back;
  in.kind = back.kind = SegmentKind::kLaneChange;
  in.start = 1.0, in.end = 4.0, in.offset = 3.5;
  back.start = 14.0, back.end = 18.0, back.offset = -3.5;
  Regime r = scripted_regime({in, back}, 0.1, 200);
  r.cases[0].start->fixed = true;
  r.cases[0].start = Start{};
  r.cases[0].start->fixed = true;
  r.cases[0].start->position = Eigen::Vector2d(3.5, 0.0);
  r.cases[0].start->velocity = Eigen::Vector2d(0.0, 3.0);
  const Track t = draw_track(r, Split::kTest, 0, 1);
  auto row = [&](double s) { return t.truth.row(static_cast<Eigen::Index>(std::lround(s / 0.1))); };
  EXPECT_DOUBLE_EQ(row(0.0)(0), 3.5);    // beside the host
  EXPECT_NEAR(row(4.0)(0), 0.0, 1e-12);  // in front of it after the cut-in
  EXPECT_NEAR(row(10.0)(0), 0.0, 1e-12);
  EXPECT_NEAR(row(19.9)(0), 3.5, 1e-12);  // back in lane 1
  EXPECT_NEAR(row(2.5)(0), 1.75, 1e-12);  // half-way through
  for (Eigen::Index k = 0; k < 200; ++k) {
    EXPECT_NEAR(t.truth(k, 3), 0.3 * static_cast<double>(k), 1e-10);  // 3 m/s faster
    EXPECT_EQ(t.truth(k, 4), 3.0);
  }
  // Peak lateral speed of a half-cosine over 3 s: π·3.5/(2·3); velocity and acceleration are the
  // derivatives of the position (central differences, away from the moves' ends).
  EXPECT_NEAR(t.truth.col(1).cwiseAbs().maxCoeff(), M_PI * 3.5 / 6.0, 1e-3);
  for (Eigen::Index k = 1; k + 1 < 200; ++k) {
    if (k == 10 || k == 40 || k == 140 || k == 180) continue;
    EXPECT_NEAR(t.truth(k, 1), (t.truth(k + 1, 0) - t.truth(k - 1, 0)) / 0.2, 0.02) << k;
    EXPECT_NEAR(t.truth(k, 2), (t.truth(k + 1, 1) - t.truth(k - 1, 1)) / 0.2, 0.05) << k;
  }
}

TEST(Track, RangeSensorPlotsAreTheDistortedPositionPlusNoiseOfCovarianceR) {
  Regime r = scripted_regime({}, 0.1, 100);
  r.sensor.kind = SensorKind::kRangeSensor;
  r.sensor.noise.sigma = Eigen::Vector2d(0.5, 1.0);
  r.sensor.noise.correlation = 0.2;
  r.cases[0].start = Start{};
  r.cases[0].start->fixed = true;
  r.cases[0].start->position = Eigen::Vector2d(1.0, 30.0);
  r.cases[0].start->velocity = Eigen::Vector2d(0.0, 5.0);
  const TrackSet set = draw_split(r, Split::kTest, 1, 300);
  const Eigen::Index k = 80;  // 70 m out: beyond the knee
  const Eigen::Vector2d clean = r.sensor.distortion.apply(position_at(set.tracks[0], k));
  EXPECT_LT(clean(1), 69.0);
  Eigen::Matrix2d sum = Eigen::Matrix2d::Zero();
  for (const Track& t : set.tracks) {
    const Eigen::Vector2d e = t.plots.row(k).transpose() - clean;
    sum += e * e.transpose() / 300.0;
  }
  EXPECT_NEAR(sum(0, 0), 0.25, 0.07);
  EXPECT_NEAR(sum(1, 1), 1.0, 0.25);
  EXPECT_NEAR(sum(0, 1), 0.1, 0.07);
}

TEST(Calibration, SamplesTheBoxWithTheConfiguredNoise) {
  Sensor sensor;
  sensor.kind = SensorKind::kRangeSensor;
  sensor.calibration.samples = 4000;
  const RangeSensorData data = draw_calibration(sensor, 5);
  ASSERT_EQ(data.positions.rows(), 4000);
  EXPECT_GE(data.positions.col(0).minCoeff(), -6.0);
  EXPECT_LE(data.positions.col(0).maxCoeff(), 6.0);
  EXPECT_GE(data.positions.col(1).minCoeff(), 1.0);
  EXPECT_LE(data.positions.col(1).maxCoeff(), 100.0);
  Eigen::MatrixXd noise(4000, 2);
  for (Eigen::Index q = 0; q < 4000; ++q) {
    noise.row(q) = data.outputs.row(q) -
                   sensor.distortion.apply(data.positions.row(q).transpose()).transpose();
  }
  for (int i = 0; i < 2; ++i) {
    EXPECT_NEAR(noise.col(i).mean(), 0.0, 4.0 * 0.05 / std::sqrt(4000.0));
    EXPECT_NEAR(std::sqrt(noise.col(i).squaredNorm() / 4000.0), 0.05, 0.003);
  }
  EXPECT_EQ(draw_calibration(sensor, 5).outputs, data.outputs);
  EXPECT_NE(draw_calibration(sensor, 6).outputs, data.outputs);
}

// The sensor "these samples came from": its response reproduces a smooth sensor from samples of
// it, inside the box, to a fraction of the samples' noise.
TEST(SampledSensor, ReproducesTheSampledDistortion) {
  Sensor sensor;
  sensor.kind = SensorKind::kRangeSensor;
  sensor.calibration.samples = 8000;
  const RangeSensorData data = draw_calibration(sensor, 1);
  const SampledSensor sampled(data.positions, data.outputs);
  double worst = 0.0;
  for (double eta : {5.0, 20.0, 40.0, 55.0, 80.0, 95.0}) {
    for (double xi : {-5.0, 0.0, 3.5}) {
      const Eigen::Vector2d p(xi, eta);
      worst =
          std::max(worst, (sampled.response(p) - sensor.distortion.apply(p)).cwiseAbs().maxCoeff());
    }
  }
  EXPECT_LT(worst, 0.04);  // below the samples' own noise, 0.05
  EXPECT_TRUE(sampled.inside(Eigen::Vector2d(0.0, 50.0)));
  EXPECT_FALSE(sampled.inside(Eigen::Vector2d(0.0, 150.0)));
  EXPECT_EQ(sampled.response(Eigen::Vector2d(0.0, 150.0)),
            sampled.response(Eigen::Vector2d(0.0, sampled.upper()(1))));
}

TEST(TrackSetFile, RoundTripPreservesEverythingAndRefusesAModelFile) {
  const testing::TempDir dir;
  Regime r = random_regime();
  r.text = "name = \"random\"\n";
  r.digest = sha256_hex(r.text);
  const TrackSet set = draw_split(r, Split::kValidation, 0, 4);
  const std::string written = write_track_set(dir / "d.h5", r, set, "v1");
  const TrackSetFile back = read_track_set(dir / "d.h5");
  EXPECT_EQ(back.digest, written);
  EXPECT_EQ(back.regime_text, r.text);
  EXPECT_EQ(back.regime_digest, r.digest);
  EXPECT_EQ(back.generator_version, "v1");
  EXPECT_EQ(back.set.split, Split::kValidation);
  ASSERT_EQ(back.set.tracks.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(back.set.tracks[i].truth, set.tracks[i].truth);
    EXPECT_EQ(back.set.tracks[i].plots, set.tracks[i].plots);
    EXPECT_EQ(back.set.tracks[i].maneuvering, set.tracks[i].maneuvering);
    EXPECT_EQ(back.set.tracks[i].noise, set.tracks[i].noise);
  }
  io::ContainerWriter other(dir / "m.h5", "immtrain-model");
  other.commit();
  EXPECT_THROW((void)read_track_set(dir / "m.h5"), io::FileError);
}

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

TEST(RangeSensorFile, RoundTripAndAlteredDataAreDetected) {
  const testing::TempDir dir;
  Regime r = scripted_regime({});
  r.sensor.kind = SensorKind::kRangeSensor;
  r.sensor.calibration.samples = 300;
  r.sensor.distortion.softness = 12.0;
  r.text = "x";
  const RangeSensorData data = draw_calibration(r.sensor, 1);
  const std::string written = write_range_sensor_dataset(dir / "r.h5", r, data, 1, "v1");
  const RangeSensorDataset back = read_range_sensor_dataset(dir / "r.h5");
  EXPECT_EQ(back.digest, written);
  EXPECT_EQ(back.digest, digest(data));
  EXPECT_EQ(back.data.positions, data.positions);
  EXPECT_EQ(back.data.outputs, data.outputs);
  EXPECT_EQ(back.regime, "test");
  EXPECT_EQ(read_sensor_samples(dir / "r.h5").outputs, data.outputs);

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
    writer.set_attribute("/parameters", "regime", std::string("test"));
    writer.set_attribute("/parameters", "regime_digest", std::string("x"));
    writer.commit();
  }
  try {
    (void)read_range_sensor_dataset(dir / "altered.h5");
    ADD_FAILURE() << "accepted";
  } catch (const io::FileError& error) {
    EXPECT_EQ(error.field(), "/@digest") << error.what();
  }
  // A track set is not a range-sensor data set, nor the other way round.
  write_track_set(dir / "t.h5", r, draw_split(r, Split::kTest, 1, 1), "v1");
  EXPECT_THROW((void)read_range_sensor_dataset(dir / "t.h5"), io::FileError);
  EXPECT_THROW((void)read_track_set(dir / "r.h5"), io::FileError);
  // CSV samples: a bad row is named by its line.
  testing::write_text(dir / "s.csv", "xi,eta,z1,z2\n# a comment\n0,1,0,1\n0,2,x,2\n");
  try {
    (void)read_sensor_samples(dir / "s.csv");
    ADD_FAILURE() << "accepted";
  } catch (const io::FileError& error) {
    EXPECT_NE(std::string(error.what()).find("s.csv:4"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace imm::datasets
