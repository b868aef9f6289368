// SPDX-License-Identifier: Apache-2.0
// Regime files: parsing (errors name file and key), the shipped presets, and the papers' scenarios
// they stand for, track for track against independent simulations of the scenarios as the SPEC
// (§7) and the seeds state them.

#include "imm/datasets/regime_file.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>

#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/random.hpp"
#include "imm/datasets/recorded.hpp"
#include "imm/datasets/sha256.hpp"
#include "imm/datasets/track.hpp"
#include "testing/config_error.hpp"
#include "testing/temp_dir.hpp"

namespace imm::datasets {
namespace {

constexpr const char* kMinimal = R"(
name = "minimal"
units = "m"
sample_period = 1.0
scans = 50
process_noise_sigma = 0.1
[sensor]
kind = "cartesian"
sigma = [10.0, 10.0]
[start]
range = [1000.0, 2000.0]
speed = [50.0, 60.0]
[[maneuvers]]
kind = "cv"
probability = 0.6
duration = [5.0, 10.0]
[[maneuvers]]
kind = "turn"
probability = 0.4
duration = [5.0, 10.0]
rate_deg = [2.0, 5.0]
[splits]
training = 3
validation = 2
test = 4
seed = 7
)";

std::string key_of(const std::string& text) {
  return testing::config_error_key(
      text, [](const std::filesystem::path& path) { return load_regime(path); });
}

std::string with(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

TEST(RegimeConfig, ReadsEveryKey) {
  const RegimeFile file = parse_regime(kMinimal, "minimal.toml");
  const Regime& r = file.regime;
  EXPECT_EQ(r.name, "minimal");
  EXPECT_EQ(r.units, datasets::Units::kMetres);
  EXPECT_EQ(r.scans, 50);
  EXPECT_EQ(r.sensor.noise.sigma, Eigen::Vector2d(10.0, 10.0));
  EXPECT_EQ(r.start.range.max, 2000.0);
  EXPECT_NEAR(r.start.bearing.max, 2.0 * std::numbers::pi, 1e-15);  // the default: any bearing
  ASSERT_EQ(r.menu.size(), 2u);
  EXPECT_NEAR(r.menu[1].rate.max, 5.0 * std::numbers::pi / 180.0, 1e-15);
  EXPECT_EQ(r.splits.test, 4);
  EXPECT_EQ(r.splits.seed, 7u);
  EXPECT_EQ(r.digest, datasets::sha256_hex(kMinimal));
  EXPECT_FALSE(r.scripted());
}

TEST(RegimeConfig, ErrorsNameTheKey) {
  EXPECT_EQ(key_of(kMinimal), "");
  EXPECT_EQ(key_of("colour = 3\n" + std::string(kMinimal)), "colour");  // unknown key
  EXPECT_EQ(key_of(with(kMinimal, "range = [1000.0, 2000.0]", "range = [2000.0, 1000.0]")),
            "start.range");  // inverted interval
  EXPECT_EQ(key_of(with(kMinimal, "sigma = [10.0, 10.0]", "sigma = [-10.0, 10.0]")),
            "sensor.sigma");  // negative σ
  EXPECT_EQ(key_of(with(kMinimal, "probability = 0.4", "probability = 0.3")),
            "maneuvers");  // probabilities sum to 0.9
  EXPECT_EQ(key_of(with(kMinimal, "sample_period = 1.0", "sample_period = 1e-320")),
            "sample_period");
  EXPECT_EQ(key_of(with(kMinimal, "kind = \"turn\"", "kind = \"loop\"")), "maneuvers[1].kind");
  EXPECT_EQ(key_of(with(kMinimal, "units = \"m\"", "units = \"ft\"")), "units");
  EXPECT_EQ(key_of(with(kMinimal, "rate_deg = [2.0, 5.0]", "rate_deg = [2.0, \"x\"]")),
            "maneuvers[1].rate_deg");
  EXPECT_EQ(key_of(with(kMinimal, "test = 4", "test = 0")), "splits.test");
  EXPECT_EQ(key_of(with(kMinimal, "[start]", "[start]\nposition = [0.0, 0.0]")), "start.velocity");
  EXPECT_EQ(key_of(with(kMinimal, "kind = \"cartesian\"", "kind = \"sonar\"")), "sensor.kind");
  // [scene]: several targets at once.
  const std::string scene = std::string(kMinimal) + "[scene]\ntargets = 4\n";
  EXPECT_EQ(key_of(scene), "");
  EXPECT_EQ(key_of(scene + "detection_probability = 1.5\n"), "scene.detection_probability");
  EXPECT_EQ(key_of(scene + "clutter_per_scan = -1.0\n"), "scene.clutter_per_scan");
  EXPECT_EQ(key_of(with(scene, "targets = 4", "targets = 0")), "scene.targets");
  EXPECT_EQ(key_of(scene + "pd = 0.9\n"), "scene.pd");  // unknown key
  // A scripted segment that ends before it starts; a case without a start.
  const std::string scripted = R"(
name = "s"
units = "km"
sample_period = 1.0
scans = 20
[sensor]
kind = "cartesian"
sigma = [0.5, 0.5]
[[cases]]
name = "one"
[cases.start]
position = [0.0, 0.0]
velocity = [0.01, 0.0]
[[cases.segments]]
kind = "ca"
start = 10.0
end = 5.0
acceleration = [0.01, 0.0]
)";
  EXPECT_EQ(key_of(scripted), "cases[0].segments[0].end");
  EXPECT_EQ(
      key_of(with(scripted, "[cases.start]\nposition = [0.0, 0.0]\nvelocity = [0.01, 0.0]\n", "")),
      "cases[0].start");
}

// Keys written in degrees are checked in degrees: a refusal's bounds are in the key's unit (a turn
// rate of −3°/s once said "must be in [0, 1000]", its bound in rad/s), and what degrees allow is
// what radians allowed (1 000 rad/s is 57 296°/s).
TEST(RegimeConfig, AnglesWrittenInDegreesAreCheckedInDegrees) {
  const auto message_of = [](const std::string& text) -> std::string {
    try {
      (void)parse_regime(text, "r.toml");
    } catch (const support::ConfigError& error) {
      return error.key() + ": " + error.what();
    }
    return "";
  };
  const std::string negative =
      message_of(with(kMinimal, "rate_deg = [2.0, 5.0]", "rate_deg = [-3.0, 5.0]"));
  EXPECT_NE(negative.find("maneuvers[1].rate_deg"), std::string::npos) << negative;
  EXPECT_NE(negative.find("57295.8] °/s"), std::string::npos) << negative;
  EXPECT_EQ(message_of(with(kMinimal, "rate_deg = [2.0, 5.0]", "rate_deg = [2.0, 57000.0]")), "");
  EXPECT_NE(message_of(with(kMinimal, "rate_deg = [2.0, 5.0]", "rate_deg = [2.0, 58000.0]"))
                .find("maneuvers[1].rate_deg"),
            std::string::npos);
  const std::string bearing =
      message_of(with(kMinimal, "[start]", "[start]\nbearing_deg = [0.0, 6000.0]"));
  EXPECT_NE(bearing.find("start.bearing_deg"), std::string::npos) << bearing;
  EXPECT_NE(bearing.find("5729.58] °"), std::string::npos) << bearing;
  EXPECT_EQ(message_of(with(kMinimal, "[start]", "[start]\nbearing_deg = [-720.0, 720.0]")), "");
  const std::string polar =
      with(with(kMinimal, "kind = \"cartesian\"", "kind = \"polar\""), "sigma = [10.0, 10.0]",
           "range_sigma = 10.0\nazimuth_sigma_deg = 200.0");
  const std::string azimuth = message_of(polar);
  EXPECT_NE(azimuth.find("sensor.azimuth_sigma_deg"), std::string::npos) << azimuth;
  EXPECT_NE(azimuth.find("183.346] °"), std::string::npos) << azimuth;
  EXPECT_EQ(message_of(with(polar, "azimuth_sigma_deg = 200.0", "azimuth_sigma_deg = 0.2")), "");
}

// A recorded regime's text with its set replaced by a stand-in: 60 agile_air tracks exported
// without truth and imported (what the nightly does), in `dir`.
std::string recorded_with_stand_in(std::string text, const testing::TempDir& dir) {
  const Regime source = load_regime("configs/regimes/agile_air.toml").regime;
  const TrackSet drawn = draw_split(source, Split::kTest, 11, 60);
  std::vector<RecordedTrack> tracks;
  for (std::size_t i = 0; i < drawn.tracks.size(); ++i) {
    const auto csv = dir.path() / std::string("r").append(std::to_string(i)).append(".csv");
    write_recording_csv(csv, drawn, SensorKind::kCartesian, i, false);
    for (auto& t : read_recording(csv, {SensorKind::kCartesian})) tracks.push_back(std::move(t));
  }
  ImportOptions options;
  const TrackSet set = import_recordings(tracks, options, nullptr);
  const auto path = dir.path() / "set.h5";
  (void)write_track_set(path, recording_header(options, set), set, "test");
  const std::size_t key = text.find("set = \"");
  const std::size_t end = text.find('"', key + 7);
  return text.replace(key + 7, end - key - 7, path.string());
}

TEST(RegimeConfig, EveryShippedRegimeLoads) {
  const testing::TempDir dir;
  int count = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator("configs/regimes")) {
    if (entry.path().extension() != ".toml") continue;
    SCOPED_TRACE(entry.path().string());
    std::ifstream in(entry.path());
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (text.find("[recorded]") != std::string::npos) {
      // Its set is the nightly's data: a stand-in set of its kind and period takes its place.
      text = recorded_with_stand_in(text, dir);
      const RegimeFile file = parse_regime(text, entry.path().string());
      EXPECT_EQ(file.regime.name, entry.path().stem().string());
      EXPECT_NO_THROW((void)datasets::draw_track(file.regime, Split::kTest, 0, 1));
      ++count;
      continue;
    }
    const RegimeFile file = load_regime(entry.path());
    EXPECT_EQ(file.regime.name, entry.path().stem().string());
    EXPECT_NO_THROW((void)datasets::draw_track(file.regime, Split::kTest, 0, 1));
    ++count;
  }
  EXPECT_GE(count, 10);
}

// --- The papers' scenarios, simulated independently ------------------------------------------

/// x(k+1) = F x(k) + G (u(k) + w(k)) per axis, the plot noise drawn before the process noise, as
/// seed 000 eq. (1)–(2); u(k) the scripted accelerations, ω(k) exact coordinated turns.
struct Reference {
  double T = 1.0;
  int scans = 0;
  double sigma_w = 0.0;
  bool polar = false;
  Eigen::Vector2d sigma, p0, v0;
  std::function<Eigen::Vector2d(int)> u = [](int) { return Eigen::Vector2d::Zero(); };
  std::function<double(int)> omega = [](int) { return 0.0; };

  void run(std::uint64_t seed, Eigen::MatrixXd& truth, Eigen::MatrixXd& plots) const {
    datasets::Rng rng(seed);
    truth.resize(scans, 4);
    plots.resize(scans, 2);
    Eigen::Vector2d p = p0, v = v0;
    for (int k = 0; k < scans; ++k) {
      truth.row(k) << p(0), v(0), p(1), v(1);
      if (polar) {
        plots(k, 0) = p.norm() + sigma(0) * rng.normal();
        plots(k, 1) = std::remainder(std::atan2(p(0), p(1)) + sigma(1) * rng.normal(),
                                     2.0 * std::numbers::pi);
      } else {
        plots(k, 0) = p(0) + sigma(0) * rng.normal();
        plots(k, 1) = p(1) + sigma(1) * rng.normal();
      }
      const Eigen::Vector2d w(sigma_w * rng.normal(), sigma_w * rng.normal());
      const Eigen::Vector2d a = u(k) + w;
      const double rate = omega(k);
      if (rate != 0.0) {
        const double s = std::sin(rate * T), c = std::cos(rate * T);
        p += Eigen::Vector2d(s * v(0) - (1.0 - c) * v(1), (1.0 - c) * v(0) + s * v(1)) / rate;
        v = Eigen::Vector2d(c * v(0) - s * v(1), s * v(0) + c * v(1));
      } else {
        p += v * T;
      }
      p += 0.5 * T * T * a;
      v += T * a;
    }
  }
};

void expect_tracks_equal(const Regime& regime, int case_index, int tracks,
                         const Reference& reference) {
  int compared = 0;
  for (int i = 0; compared < tracks; ++i) {
    const Track track = datasets::draw_track(regime, Split::kTest, i, regime.splits.seed);
    if (track.case_index != case_index) continue;
    Eigen::MatrixXd truth, plots;
    reference.run(datasets::derive_seed(regime.splits.seed, static_cast<std::uint64_t>(i)), truth,
                  plots);
    const double scale = truth.cwiseAbs().maxCoeff();
    for (int k = 0; k < reference.scans; ++k) {
      const Eigen::Vector4d ours(track.truth(k, 0), track.truth(k, 1), track.truth(k, 3),
                                 track.truth(k, 4));
      ASSERT_LE((ours - truth.row(k).transpose()).cwiseAbs().maxCoeff(), 1e-12 * scale)
          << "track " << i << ", scan " << k;
      ASSERT_LE((track.plots.row(k) - plots.row(k)).cwiseAbs().maxCoeff(), 1e-12 * scale)
          << "track " << i << ", scan " << k;
    }
    ++compared;
  }
}

TEST(PaperPresets, GaImmTable3TrackForTrack) {
  const Regime r = load_regime("configs/regimes/paper/ga_imm_table3.toml").regime;
  Reference s;
  s.scans = 160;
  s.sigma_w = 0.001;
  s.sigma = Eigen::Vector2d(0.5, 0.5);
  const double c = std::cos(std::numbers::pi / 4.0);
  s.p0 = 22.4 * Eigen::Vector2d(c, c);
  s.v0 = 0.015 * Eigen::Vector2d(c, c);
  s.u = [](int k) -> Eigen::Vector2d {
    if (k >= 40 && k < 60) return {0.01, 0.0};
    if (k >= 80 && k < 90) return {0.0, 0.06};
    if (k >= 120 && k < 140) return {-0.03, 0.0};
    return Eigen::Vector2d::Zero();
  };
  expect_tracks_equal(r, 0, 5, s);
  EXPECT_EQ(r.splits.test, 100);
}

TEST(PaperPresets, FcmImmZigzagTrackForTrack) {
  for (const auto& preset : {std::pair<std::string, double>{"fcm_imm_zigzag.toml", 1.0},
                             {"fcm_imm_zigzag_literal.toml", 10.0}}) {
    const std::string& file = preset.first;
    const double scale = preset.second;  // a named copy: the lambda below captures it
    const Regime r = load_regime("configs/regimes/paper/" + file).regime;
    Reference s;
    s.scans = 400;
    s.sigma_w = 0.5;
    s.sigma = Eigen::Vector2d(100.0, 100.0);
    s.p0 = Eigen::Vector2d(300e3, 200e3);
    const Eigen::Vector2d heading = -s.p0.normalized();
    s.v0 = 450.0 * heading;
    const Eigen::Vector2d lateral(-heading.y(), heading.x());
    // Four periods of 32 s from 136 s: +a, −a, −a, +a per 8-s quarter, a = 30, −40, 50, −60.
    s.u = [=](int k) -> Eigen::Vector2d {
      if (k < 136 || k >= 264) return Eigen::Vector2d::Zero();
      const int period = (k - 136) / 32, quarter = ((k - 136) % 32) / 8;
      const double a = scale * (30.0 + 10.0 * period) * (period % 2 == 0 ? 1.0 : -1.0);
      return (quarter == 0 || quarter == 3 ? a : -a) * lateral;
    };
    expect_tracks_equal(r, 0, 3, s);
  }
}

TEST(PaperPresets, WimmTable2ScenariosTrackForTrack) {
  const Regime r = load_regime("configs/regimes/paper/wimm_table2.toml").regime;
  ASSERT_EQ(r.case_count(), 2);
  for (int scenario : {1, 2}) {
    Reference s;
    s.T = 2.0;
    s.scans = 250;
    s.polar = true;
    s.sigma = Eigen::Vector2d(50.0, 0.5 * std::numbers::pi / 180.0);
    const double c = std::cos(std::numbers::pi / 4.0);
    s.p0 = 140e3 * Eigen::Vector2d(c, c);
    s.v0 = Eigen::Vector2d(-100.0, -100.0);
    if (scenario == 2) {
      // 200–224 s and 276–300 s: transitions 100–111 and 138–149.
      s.omega = [](int k) {
        return (k >= 100 && k < 112) || (k >= 138 && k < 150) ? 3.82 * std::numbers::pi / 180.0
                                                              : 0.0;
      };
    }
    expect_tracks_equal(r, scenario - 1, 3, s);
  }
}

// Seed 002's cut-in: the truth of §4 (half-cosine lane changes), the plots the distorted position
// plus N(0, R) with R per case.
TEST(PaperPresets, FimmTable1CutInTruthAndNoiseLevels) {
  for (const char* file : {"fimm_table1.toml", "fimm_table1_hard.toml"}) {
    const Regime r = load_regime(std::string("configs/regimes/paper/") + file).regime;
    ASSERT_EQ(r.case_count(), 4);
    const double sigmas[4] = {0.1, 0.5, 1.0, 2.0};
    for (int i = 0; i < 8; ++i) {
      const Track t = datasets::draw_track(r, Split::kTest, i, 1);
      EXPECT_EQ(t.case_index, i % 4);
      EXPECT_EQ(t.noise.sigma, Eigen::Vector2d::Constant(sigmas[i % 4]));
      for (int k = 0; k < 200; ++k) {
        const double time = 0.1 * k;
        auto half_cosine = [&](double t0, double t1, double a, double b) {
          if (time <= t0) return a;
          if (time >= t1) return b;
          return a + 0.5 * (b - a) * (1.0 - std::cos(std::numbers::pi * (time - t0) / (t1 - t0)));
        };
        const double xi =
            time < 14.0 ? half_cosine(1.0, 4.0, 3.5, 0.0) : half_cosine(14.0, 18.0, 0.0, 3.5);
        ASSERT_NEAR(t.truth(k, 0), xi, 1e-12) << k;
        ASSERT_NEAR(t.truth(k, 3), 3.0 * time, 1e-10) << k;
      }
    }
  }
  EXPECT_EQ(
      load_regime("configs/regimes/paper/fimm_table1_hard.toml").regime.sensor.distortion.softness,
      10.0);
}

// Seed 001's rows: every track is two independent runs of the paper's one-axis trajectory.
TEST(PaperPresets, InputEstimatorTablesRowsOnBothAxes) {
  const Regime r = load_regime("configs/regimes/paper/input_estimator_tables.toml").regime;
  ASSERT_EQ(r.case_count(), 8);
  const RegimeFile file = load_regime("configs/regimes/paper/input_estimator_tables.toml");
  ASSERT_NE(file.find("corrected KF", "4 m/s² 15 s + 8 m/s² 30 s", "position_mse"), nullptr);
  EXPECT_EQ(file.find("corrected KF", "4 m/s² 15 s + 8 m/s² 30 s", "position_mse")->value, 7.14e3);
  const Track t = datasets::draw_track(r, Split::kTest, 6, 1);  // case 6: 4 m/s² 15 s + 8 30 s
  for (int k = 0; k < 300; ++k) {
    const double a = k >= 100 && k < 115 ? 4.0 : k >= 185 && k < 215 ? 8.0 : 0.0;
    EXPECT_EQ(t.truth(k, 2), a) << k;
    EXPECT_EQ(t.truth(k, 5), a) << k;
  }
}

}  // namespace
}  // namespace imm::datasets
