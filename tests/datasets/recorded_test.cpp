// SPDX-License-Identifier: Apache-2.0
// Recorded tracks: import round trips, hostile recordings, recorded regimes' splits, and the plot σ
// learned from plots alone.

#include "imm/datasets/recorded.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>
#include <set>
#include <streambuf>

#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/regime_file.hpp"
#include "imm/datasets/sensor_estimate.hpp"
#include "imm/support/csv.hpp"
#include "testing/refused_field.hpp"
#include "testing/temp_dir.hpp"

namespace imm::datasets {
namespace {

using testing::TempDir;

Regime agile_air() { return load_regime("configs/regimes/agile_air.toml").regime; }

void write_text(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// The message of the std::runtime_error `f` throws ("" when it does not).
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const std::exception& error) {
    return error.what();
  }
  return "";
}

std::vector<RecordedTrack> read_all(const std::vector<std::filesystem::path>& files) {
  std::vector<RecordedTrack> tracks;
  for (const auto& file : files) {
    for (auto& t : read_recording(file, {SensorKind::kCartesian})) tracks.push_back(std::move(t));
  }
  return tracks;
}

TEST(RecordedTracks, ExportThenImportGivesTheSamePlotsAndTruthToTheBit) {
  const Regime regime = agile_air();
  const TrackSet drawn = draw_split(regime, Split::kTest, 7, 4);
  TempDir dir;
  std::vector<std::filesystem::path> files;
  for (std::size_t i = 0; i < drawn.tracks.size(); ++i) {
    files.push_back(dir.path() / std::string("track_").append(std::to_string(i)).append(".csv"));
    write_recording_csv(files.back(), drawn, SensorKind::kCartesian, i, true);
  }
  ImportReport report;
  const TrackSet set = import_recordings(read_all(files), {}, &report);
  EXPECT_EQ(report.recordings, 4);
  EXPECT_EQ(report.gap_scans, 0);
  EXPECT_EQ(report.dropped_scans, 0);
  EXPECT_EQ(set.sample_period, regime.sample_period);
  ASSERT_EQ(set.tracks.size(), drawn.tracks.size());
  EXPECT_TRUE(set.has_truth);
  for (std::size_t i = 0; i < set.tracks.size(); ++i) {
    EXPECT_TRUE((set.tracks[i].plots.array() == drawn.tracks[i].plots.array()).all()) << i;
    for (Eigen::Index column : {0, 1, 3, 4}) {
      EXPECT_TRUE(
          (set.tracks[i].truth.col(column).array() == drawn.tracks[i].truth.col(column).array())
              .all())
          << i << " column " << column;
    }
    // Accelerations are the velocity's forward differences.
    const Track& t = set.tracks[i];
    EXPECT_DOUBLE_EQ(t.truth(5, 2), (t.truth(6, 1) - t.truth(5, 1)) / regime.sample_period);
  }
  // The file round trip keeps every bit and the recordings.
  const auto path = dir.path() / "set.h5";
  ImportOptions options;
  const std::string digest = write_track_set(path, recording_header(options, set), set, "test");
  const TrackSetFile file = read_track_set(path);
  EXPECT_EQ(file.digest, digest);
  EXPECT_TRUE(file.set.recorded);
  EXPECT_EQ(file.set.recording, set.recording);
  EXPECT_EQ(file.set.recording_names, set.recording_names);
  for (std::size_t i = 0; i < set.tracks.size(); ++i) {
    EXPECT_TRUE((file.set.tracks[i].plots.array() == set.tracks[i].plots.array()).all());
  }
}

TEST(RecordedTracks, OneFileWithATrackColumnGapsAndWindows) {
  TempDir dir;
  // Track "a": 9 scans with a gap at t = 3 and 4; track "b" interleaved: 4 scans.
  std::string text = "# a comment\nt,track,zx,zy\n";
  for (int k = 0; k < 9; ++k) {
    if (k != 3 && k != 4) {
      text.append(std::to_string(0.5 * k + 100.0)).append(",a,").append(std::to_string(k));
      text.append(",1\n");
    }
    if (k < 4)
      text.append(std::to_string(0.5 * k)).append(",b,2,").append(std::to_string(k) + "\n");
  }
  write_text(dir.path() / "all.csv", text);
  const auto tracks = read_recording(dir.path() / "all.csv", {SensorKind::kCartesian});
  ASSERT_EQ(tracks.size(), 2U);
  EXPECT_EQ(tracks[0].name, "a");
  EXPECT_EQ(tracks[1].name, "b");
  ImportOptions options;
  options.scans = 3;
  ImportReport report;
  const TrackSet set = import_recordings(tracks, options, &report);
  EXPECT_EQ(set.sample_period, 0.5);
  EXPECT_FALSE(set.has_truth);
  // a: 9 scans → 3 windows; b: 4 scans → 1 window and 1 scan dropped.
  ASSERT_EQ(set.tracks.size(), 4U);
  EXPECT_EQ(set.recording, (std::vector<int>{0, 0, 0, 1}));
  EXPECT_EQ(report.gap_scans, 2);
  EXPECT_EQ(report.dropped_scans, 1);
  EXPECT_TRUE(std::isnan(set.tracks[1].plots(0, 0)));  // scan 3
  EXPECT_TRUE(std::isnan(set.tracks[1].plots(1, 1)));  // scan 4
  EXPECT_EQ(set.tracks[1].plots(2, 0), 5.0);
  EXPECT_TRUE(set.tracks[0].truth.array().isNaN().all());
  // The gaps are written as missing values and read back as NaN, the rest to the bit.
  write_track_set(dir.path() / "gaps.h5", recording_header(options, set), set, "test");
  const TrackSet read = read_track_set(dir.path() / "gaps.h5").set;
  EXPECT_EQ(read.digest(), set.digest());
  EXPECT_TRUE(std::isnan(read.tracks[1].plots(0, 0)) && std::isnan(read.tracks[1].plots(1, 1)));
  EXPECT_EQ(read.tracks[1].plots(2, 0), 5.0);
  // ±∞ is never a missing value.
  TrackSet infinite = set;
  infinite.tracks[2].plots(0, 0) = std::numeric_limits<double>::infinity();
  EXPECT_NE(error_of([&] {
              (void)write_track_set(dir.path() / "inf.h5", recording_header(options, infinite),
                                    infinite, "test");
            }).find("non-finite"),
            std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "inf.h5"));
}

TEST(RecordedTracks, HostileRecordingsAreRefusedWithFileLineAndColumn) {
  TempDir dir;
  struct Case {
    std::string name, text, expected;
  };
  const std::vector<Case> cases = {
      {"unsorted", "t,zx,zy\n0,1,2\n2,1,2\n1,1,2\n", "unsorted.csv:4: column 1 ('t')"},
      {"jump", "t,zx,zy\n0,1,2\n1,1,2\n2,1,2\n3.5,1,2\n", "jump.csv:5: column 't'"},
      {"nan", "t,zx,zy\n0,1,2\n1,nan,2\n", "nan.csv:3: column 2: 'nan'"},
      {"inf", "t,zx,zy\n0,1,2\n1,1,-inf\n", "inf.csv:3: column 3: '-inf'"},
      {"missing", "t,zx\n0,1\n", "missing.csv:1: header: the column 'zy' is missing"},
      {"unknown", "t,zx,zy,speed\n0,1,2,3\n", "unknown.csv:1: header: column 4 ('speed')"},
      {"short_row", "t,zx,zy\n0,1,2\n1,2\n", "short_row.csv:3: has 2 columns"},
      {"empty", "", "empty.csv:1: the file is empty"},
      {"header_only", "t,zx,zy\n", "header_only.csv: no plots"},
      {"half_truth", "t,zx,zy,x,vx\n0,1,2,3,4\n", "half_truth.csv:1: header: truth needs"},
      {"twice", "t,zx,zy\n0,1,2\n0.001,1,2\n1,1,2\n", "twice.csv:3: column 't': two plots"},
      {"far", "t,zx,zy\n0,1,2\n1,1,2\n1000000,1,2\n", "far.csv:4: column 't': more than 10⁶"},
      {"same_time", "t,zx,zy\n0,1,2\n1,1,2\n1,1,2.5\n",
       "same_time.csv:4: column 1 ('t'): track 'same_time' has another plot at the time of line 3"},
  };
  for (const Case& c : cases) {
    const auto path = dir.path() / (c.name + ".csv");
    write_text(path, c.text);
    const std::string error = error_of([&] {
      const auto tracks = read_recording(path, {SensorKind::kCartesian});
      ImportOptions options;
      options.sample_period = 1.0;
      (void)import_recordings(tracks, options, nullptr);
    });
    EXPECT_NE(error.find(c.expected), std::string::npos) << c.name << ": " << error;
  }
}

// A logger that wrote a line twice: the exact repeat of a track's line before it is dropped and
// counted (the whole recording was refused as "the times must increase"); the set is the one
// without it, to the bit. A repeat that is not next to its line is still refused.
TEST(RecordedTracks, AnExactlyRepeatedLineIsDroppedAndCounted) {
  TempDir dir;
  const std::string clean =
      "t,track,zx,zy,x,vx,y,vy\n0,a,1,2,1,0,2,0\n0,b,5,6,5,0,6,0\n1,a,1.5,2,1,0,2,0\n"
      "1,b,5,6.5,5,0,6,0\n2,a,2,2,1,0,2,0\n2,b,5,7,5,0,6,0\n3,a,2.5,2,1,0,2,0\n";
  // Line 4 (a at t = 1) written again after line 5 (b's), and b's last line twice in a row.
  const std::string repeated =
      "t,track,zx,zy,x,vx,y,vy\n0,a,1,2,1,0,2,0\n0,b,5,6,5,0,6,0\n1,a,1.5,2,1,0,2,0\n"
      "1,b,5,6.5,5,0,6,0\n1,a,1.5,2,1,0,2,0\n2,a,2,2,1,0,2,0\n2,b,5,7,5,0,6,0\n"
      "2,b,5,7,5,0,6,0\n3,a,2.5,2,1,0,2,0\n";
  write_text(dir.path() / "clean.csv", clean);
  write_text(dir.path() / "repeated.csv", repeated);
  ImportOptions options;
  options.scans = 3;
  ImportReport clean_report, repeated_report;
  const auto clean_tracks = read_recording(dir.path() / "clean.csv", {SensorKind::kCartesian});
  const auto tracks = read_recording(dir.path() / "repeated.csv", {SensorKind::kCartesian});
  ASSERT_EQ(tracks.size(), 2U);
  EXPECT_EQ(tracks[0].repeated_lines, (std::vector<std::size_t>{6}));
  EXPECT_EQ(tracks[1].repeated_lines, (std::vector<std::size_t>{9}));
  EXPECT_EQ(tracks[0].lines, (std::vector<std::size_t>{2, 4, 7, 10}));
  EXPECT_EQ(tracks[1].lines, (std::vector<std::size_t>{3, 5, 8}));
  const TrackSet expected = import_recordings(clean_tracks, options, &clean_report);
  const TrackSet set = import_recordings(tracks, options, &repeated_report);
  EXPECT_EQ(clean_report.repeated_lines, 0);
  EXPECT_EQ(repeated_report.repeated_lines, 2);
  EXPECT_EQ(set.digest(), expected.digest());
  ASSERT_EQ(set.tracks.size(), expected.tracks.size());
  for (std::size_t i = 0; i < set.tracks.size(); ++i) {
    EXPECT_EQ(set.tracks[i].plots, expected.tracks[i].plots);
    EXPECT_EQ(set.tracks[i].truth, expected.tracks[i].truth);
  }
  // Not next to its line: the times go back, as before.
  write_text(dir.path() / "back.csv", "t,zx,zy\n0,1,2\n1,1,2\n2,1,2\n1,1,2\n");
  EXPECT_NE(error_of([&] {
              (void)read_recording(dir.path() / "back.csv", {SensorKind::kCartesian});
            }).find("back.csv:5: column 1 ('t'): the times of track 'back' must increase"),
            std::string::npos);
}

// A sample period given is held to a sample period's limits (NaN is not "infer it"), and one
// inferred from the plots too: before, 1e300 s read the second plot as "two plots on one scan of
// 1e300 s" (printed with 300 digits), NaN said "no track has two plots".
TEST(RecordedTracks, ASamplePeriodOutsideASamplePeriodsLimitsIsRefused) {
  TempDir dir;
  write_text(dir.path() / "a.csv", "t,zx,zy\n0,1,2\n1,2,3\n2,3,4\n3,4,5\n");
  const auto tracks = read_recording(dir.path() / "a.csv", {SensorKind::kCartesian});
  for (const double period :
       {std::nan(""), 1e300, -1.0, 1e-9, 36001.0, std::numeric_limits<double>::infinity()}) {
    ImportOptions options;
    options.sample_period = period;
    EXPECT_EQ(testing::refused_field_of([&] { (void)import_recordings(tracks, options, nullptr); }),
              "sample_period")
        << period;
  }
  ImportOptions inferred;
  EXPECT_EQ(import_recordings(tracks, inferred, nullptr).sample_period, 1.0);
  write_text(dir.path() / "fast.csv", "t,zx,zy\n0,1,2\n1e-8,2,3\n2e-8,3,4\n3e-8,4,5\n");
  const auto fast = read_recording(dir.path() / "fast.csv", {SensorKind::kCartesian});
  EXPECT_NE(error_of([&] {
              (void)import_recordings(fast, inferred, nullptr);
            }).find("the first track's median step, 1e-08 s, is not a sample period"),
            std::string::npos);
}

// An endless line: the reader refuses it after kMaxLineBytes, without reading it whole.
class EndlessLine : public std::streambuf {
 public:
  EndlessLine() { setg(block_.data(), block_.data(), block_.data() + block_.size()); }

 protected:
  int_type underflow() override {
    served_ += block_.size();
    setg(block_.data(), block_.data(), block_.data() + block_.size());
    return traits_type::to_int_type(block_[0]);
  }

 public:
  std::size_t served_ = 0;

 private:
  std::array<char, 4096> block_ = [] {
    std::array<char, 4096> a{};
    a.fill('7');
    return a;
  }();
};

TEST(RecordedTracks, ATwoGigabyteLineIsRefusedAfterAMegabyte) {
  EndlessLine endless;
  std::istream in(&endless);
  support::CsvReader reader(in, "endless.csv");
  support::CsvLine line;
  const std::string error = error_of([&] { (void)reader.next(line); });
  EXPECT_NE(error.find("endless.csv:1: the line is longer than"), std::string::npos) << error;
  EXPECT_LT(endless.served_, 2 * support::CsvReader::kMaxLineBytes);
}

TEST(RecordedRegime, SplitsKeepARecordingsWindowsTogetherAndFollowTheSeed) {
  TempDir dir;
  const Regime source = agile_air();
  const TrackSet drawn = draw_split(source, Split::kTest, 3, 10);
  std::vector<std::filesystem::path> files;
  for (std::size_t i = 0; i < drawn.tracks.size(); ++i) {
    files.push_back(dir.path() / std::string("r").append(std::to_string(i)).append(".csv"));
    write_recording_csv(files.back(), drawn, SensorKind::kCartesian, i, false);
  }
  ImportOptions options;
  options.scans = 50;  // 4 windows per recording
  const TrackSet set = import_recordings(read_all(files), options, nullptr);
  write_track_set(dir.path() / "set.h5", recording_header(options, set), set, "test");
  auto regime_text = [&](int seed, const char* test = "3") {
    std::string text = "name = \"r\"\nunits = \"m\"\n[recorded]\nset = \"";
    text.append((dir.path() / "set.h5").string())
        .append("\"\n[sensor]\nkind = \"cartesian\"\nsigma = [30.0, 30.0]\n[splits]\n")
        .append("training = 5\nvalidation = 2\ntest = ")
        .append(test)
        .append("\nseed = ")
        .append(std::to_string(seed))
        .append("\n");
    return text;
  };
  const Regime a = parse_regime(regime_text(1), "a.toml").regime;
  EXPECT_EQ(split_size(a, Split::kTraining), 20);
  EXPECT_EQ(split_size(a, Split::kValidation), 8);
  EXPECT_EQ(split_size(a, Split::kTest), 12);
  std::set<int> seen;
  for (Split split : {Split::kTraining, Split::kValidation, Split::kTest}) {
    const TrackSet s = draw_split(a, split, 99);
    std::set<int> recordings(s.recording.begin(), s.recording.end());
    for (int r : recordings) EXPECT_TRUE(seen.insert(r).second) << "recording " << r << " twice";
    EXPECT_EQ(recordings.size() * 4, s.tracks.size());
    EXPECT_EQ(s.tracks[1].plots, draw_track(a, split, 1, 5).plots);
    EXPECT_EQ(s.scans, 50);
  }
  EXPECT_EQ(seen.size(), 10U);
  const Regime b = parse_regime(regime_text(2), "b.toml").regime;
  EXPECT_NE(draw_split(a, Split::kTraining, 1).recording,
            draw_split(b, Split::kTraining, 1).recording);
  EXPECT_NE(a.digest, b.digest);
  // More recordings than the set holds, and generator keys, are refused by name.
  EXPECT_NE(error_of([&] { (void)parse_regime(regime_text(1, "4"), "c.toml"); }).find("splits"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              (void)parse_regime(regime_text(1) + "process_noise_sigma = 1.0\n", "d.toml");
            }).find("process_noise_sigma"),
            std::string::npos);
}

// Truth for some recordings (a GPS track for a few): it survives the file, goes where the regime
// uses it — the test split with recorded.truth = "evaluation", the training and validation splits
// with "training" — and a split learns from truth only when all of it has truth.
TEST(RecordedRegime, PartialTruthGoesWhereTheRegimeUsesIt) {
  TempDir dir;
  const TrackSet drawn = draw_split(agile_air(), Split::kTest, 3, 10);
  std::vector<std::filesystem::path> files;
  const std::set<std::size_t> with_truth = {1, 4, 6, 9};
  for (std::size_t i = 0; i < drawn.tracks.size(); ++i) {
    files.push_back(dir.path() / std::string("r").append(std::to_string(i)).append(".csv"));
    write_recording_csv(files.back(), drawn, SensorKind::kCartesian, i, with_truth.contains(i));
  }
  ImportOptions options;
  options.scans = 100;  // 2 windows per recording
  const TrackSet set = import_recordings(read_all(files), options, nullptr);
  EXPECT_FALSE(set.has_truth);
  ASSERT_EQ(set.recording_truth.size(), 10U);
  for (std::size_t r = 0; r < 10; ++r) EXPECT_EQ(set.recording_truth[r], with_truth.contains(r));
  write_track_set(dir.path() / "set.h5", recording_header(options, set), set, "test");
  const TrackSet read = read_track_set(dir.path() / "set.h5").set;
  EXPECT_EQ(read.recording_truth, set.recording_truth);
  EXPECT_EQ(read.digest(), set.digest());
  EXPECT_TRUE(read.tracks[2].truth.allFinite());  // recording 1's first window
  EXPECT_TRUE(read.tracks[0].truth.array().isNaN().all());
  EXPECT_EQ(read.tracks[2].truth.col(0), drawn.tracks[1].truth.col(0).head(100));

  auto regime = [&](const char* truth, int training, int validation, int test) {
    const std::string text =
        "name = \"r\"\nunits = \"m\"\n[recorded]\nset = \"" + (dir.path() / "set.h5").string() +
        "\"\ntruth = \"" + truth +
        "\"\nacceleration = [1.0, 50.0]\n[sensor]\nkind = \"cartesian\"\nsigma = [30.0, 30.0]\n"
        "[splits]\ntraining = " +
        std::to_string(training) + "\nvalidation = " + std::to_string(validation) +
        "\ntest = " + std::to_string(test) + "\n";
    return parse_regime(text, "p.toml").regime;
  };
  auto truth_recordings = [](const TrackSet& split) {
    std::set<int> recordings;
    for (std::size_t i = 0; i < split.tracks.size(); ++i) {
      if (split.tracks[i].truth.allFinite()) recordings.insert(split.recording[i]);
      EXPECT_EQ(split.tracks[i].truth.allFinite(), split.track_has_truth(i));
    }
    return recordings;
  };
  // For evaluation: the test split is dealt first, from the recordings with truth.
  const Regime evaluation = regime("evaluation", 5, 2, 3);
  const TrackSet test = draw_split(evaluation, Split::kTest, 1);
  EXPECT_TRUE(test.has_truth);
  EXPECT_EQ(truth_recordings(test).size(), 3U);
  for (const Split split : {Split::kTraining, Split::kValidation}) {
    EXPECT_TRUE(truth_recordings(draw_split(evaluation, split, 1)).empty());
  }
  EXPECT_FALSE(evaluation.trains_from_truth());
  // Six test recordings hold the four with truth: a partial split, judged by its plots.
  const TrackSet mixed = draw_split(regime("evaluation", 2, 2, 6), Split::kTest, 1);
  EXPECT_FALSE(mixed.has_truth);
  EXPECT_EQ(truth_recordings(mixed), std::set<int>({1, 4, 6, 9}));
  // For training: the training and validation splits take them first; all four fit in 3 + 1.
  const Regime training = regime("training", 3, 1, 6);
  EXPECT_TRUE(training.trains_from_truth());
  EXPECT_EQ(truth_recordings(draw_split(training, Split::kTraining, 1)).size(), 3U);
  EXPECT_TRUE(draw_split(training, Split::kValidation, 1).has_truth);
  EXPECT_TRUE(truth_recordings(draw_split(training, Split::kTest, 1)).empty());
  // Five training recordings cannot all have truth: the trainers learn from the plots.
  EXPECT_FALSE(regime("training", 5, 1, 4).trains_from_truth());
  EXPECT_FALSE(draw_split(regime("training", 5, 1, 4), Split::kTraining, 1).has_truth);
}

TEST(PlotSigma, LearnedFromPlotsAloneWithinFivePercentOnThirtyAgileAirTracks) {
  const Regime regime = agile_air();
  const TrackSet set = draw_split(regime, Split::kTest, 11, 30);
  const PlotSigmaFit fit = fit_plot_sigma(set);
  EXPECT_NEAR(fit.model.sigma, 30.0, 0.05 * 30.0) << "start " << fit.start_sigma;
  EXPECT_LE(fit.model.quiet_noise, fit.model.manoeuvre_noise);
}

// A polar sensor's σ_r and σ_θ from the plots alone: 30 air_surveillance tracks (σ_r 100 m,
// σ_θ 0.2°), every target inbound from all bearings (the azimuth crosses ±π on some).
TEST(PlotSigma, PolarRangeAndAzimuthWithinFivePercentOnThirtyAirSurveillanceTracks) {
  const Regime regime = load_regime("configs/regimes/air_surveillance.toml").regime;
  const TrackSet set = draw_split(regime, Split::kTest, 11, 30);
  const PolarSigmaFit fit = fit_polar_sigma(set);
  EXPECT_NEAR(fit.range.model.sigma, 100.0, 5.0);
  EXPECT_NEAR(fit.azimuth.model.sigma / (0.2 * std::numbers::pi / 180.0), 1.0, 0.05);
}

}  // namespace
}  // namespace imm::datasets
