// SPDX-License-Identifier: Apache-2.0
// The Monte Carlo loop on recorded plots without truth: the same plots give the same NIS and
// predictive log-likelihoods with or without truth, the log-likelihoods are the filter's own, and
// the headline is the plots' (predictive NLL, NIS, innovation RMS).

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/recorded.hpp"
#include "imm/datasets/regime_file.hpp"
#include "imm/evaluation/experiment.hpp"
#include "imm/evaluation/monte_carlo.hpp"
#include "imm/evaluation/tracker_choice.hpp"
#include "imm/filters/axis_cv_imm.hpp"
#include "testing/temp_dir.hpp"

namespace imm::evaluation {
namespace {

AxisCvImmSpec agile_air_imm() {
  AxisCvImmSpec spec;
  spec.settings.sample_period = 1.0;
  spec.settings.measurement_sigma = 30.0;
  spec.process_noise = {0.25, 100.0, 3000.0};
  return spec;
}

TEST(PlotMetrics, TheSamePlotsScoreTheSameWithoutTruthAndTheLikelihoodIsTheFiltersOwn) {
  const datasets::Regime regime = datasets::load_regime("configs/regimes/agile_air.toml").regime;
  const datasets::TrackSet with = datasets::draw_split(regime, datasets::Split::kTest, 5, 4);
  datasets::TrackSet without = with;
  without.has_truth = false;
  for (auto& track : without.tracks) {
    track.truth.setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  // A gap in one track: predicted through, scored nowhere.
  without.tracks[1].plots.row(40).setConstant(std::numeric_limits<double>::quiet_NaN());
  const AxisCvImmSpec spec = agile_air_imm();
  const FilterFactory make = [&] { return make_axis_cv_imm_filter(spec); };
  const FilterOutcome a = run_monte_carlo("imm", make, spec.track_options(), with);
  const FilterOutcome b = run_monte_carlo("imm", make, spec.track_options(), without);
  EXPECT_TRUE(a.has_truth);
  EXPECT_FALSE(b.has_truth);
  EXPECT_GT(a.zeta_p, 0.0);
  EXPECT_EQ(b.run_counted.sum(), 0.0);
  for (Eigen::Index r : {0, 2, 3}) {
    for (Eigen::Index k = 0; k < a.run_nis.cols(); ++k) {
      ASSERT_EQ(std::isnan(a.run_nis(r, k)), std::isnan(b.run_nis(r, k)));
      if (std::isnan(a.run_nis(r, k))) continue;
      ASSERT_EQ(a.run_nis(r, k), b.run_nis(r, k));
      ASSERT_EQ(a.run_log_likelihood(r, k), b.run_log_likelihood(r, k));
    }
  }
  EXPECT_TRUE(std::isnan(b.run_log_likelihood(1, 40)));
  // Track 0's log-likelihoods are those of a tracker run by hand.
  Tracker tracker(make(), spec.track_options());
  for (Eigen::Index k = 0; k < with.scans; ++k) {
    const TrackStepResult result = tracker.process(k, with.tracks[0].plots.row(k).transpose());
    if (result.event != TrackEvent::kUpdated) {
      EXPECT_TRUE(std::isnan(b.run_log_likelihood(0, k))) << k;
      continue;
    }
    ASSERT_EQ(b.run_log_likelihood(0, k), tracker.filter().log_predictive_likelihood()) << k;
  }
  const std::vector<HeadlineMetric> headline = b.headline();
  ASSERT_EQ(headline.size(), 3U);
  EXPECT_EQ(headline[0].name, "predictive_nll");
  EXPECT_EQ(headline[1].name, "nis_log_ratio");
  EXPECT_EQ(headline[2].name, "innovation_rms");
  // The NLL per plot is the mean of the finite −log-likelihoods.
  double sum = 0.0, count = 0.0;
  for (Eigen::Index r = 0; r < b.run_log_likelihood.rows(); ++r) {
    for (Eigen::Index k = 0; k < b.run_log_likelihood.cols(); ++k) {
      if (std::isfinite(b.run_log_likelihood(r, k))) sum -= b.run_log_likelihood(r, k), ++count;
    }
  }
  EXPECT_NEAR(headline[0].value(), sum / count, 1e-12 * std::abs(sum / count));
  // An innovation RMS of the size of the plot σ (√2 · 30 m for two axes, a little more with
  // the prediction's own uncertainty).
  EXPECT_GT(headline[2].value(), 30.0 * std::sqrt(2.0));
  EXPECT_LT(headline[2].value(), 3.0 * 30.0 * std::sqrt(2.0));
  EXPECT_EQ(a.headline()[0].name, "zeta_p");  // with truth, the headline is unchanged
}

// A recorded regime without truth gives its test tracks to be judged by the plots, and asking for
// the tracks with truth (--truth-tracks) is refused, naming the regime; a model runs on plots
// whose σ was estimated near its own, not beyond.
TEST(PlotMetrics, ARecordedRegimeWithoutTruthGivesPlotsAndRefusesTruthTracks) {
  const testing::TempDir dir;
  const datasets::Regime source = datasets::load_regime("configs/regimes/agile_air.toml").regime;
  const datasets::TrackSet drawn = datasets::draw_split(source, datasets::Split::kTest, 5, 6);
  std::vector<datasets::RecordedTrack> tracks;
  for (std::size_t i = 0; i < drawn.tracks.size(); ++i) {
    const auto csv = dir.path() / std::string("r").append(std::to_string(i)).append(".csv");
    datasets::write_recording_csv(csv, drawn, datasets::SensorKind::kCartesian, i, false);
    for (auto& t : datasets::read_recording(csv, {datasets::SensorKind::kCartesian})) {
      tracks.push_back(std::move(t));
    }
  }
  const datasets::ImportOptions options;
  const datasets::TrackSet set = datasets::import_recordings(tracks, options, nullptr);
  (void)datasets::write_track_set(dir.path() / "set.h5", datasets::recording_header(options, set),
                                  set, "test");
  std::string text = "name = \"r\"\nunits = \"m\"\n[recorded]\nset = \"";
  text.append((dir.path() / "set.h5").string())
      .append("\"\n[sensor]\nkind = \"cartesian\"\nsigma = [30.0, 30.0]\n[splits]\n")
      .append("training = 2\nvalidation = 2\ntest = 2\n");
  const datasets::Regime recorded = datasets::parse_regime(text, "r.toml").regime;
  // A model built for σ = 30 m runs on recorded plots whose σ was estimated near it, not beyond.
  std::string estimated = text;
  estimated.replace(estimated.find("[30.0, 30.0]"), 12, "\"estimate\"");
  EvaluationRegimes regimes{datasets::parse_regime(estimated, "e.toml"),
                            datasets::load_regime("configs/regimes/agile_air.toml")};
  const double sigma = regimes.evaluated.regime.sensor.noise.sigma(0);
  EXPECT_GT(std::abs(sigma - 30.0), 0.0);
  EXPECT_LT(std::abs(sigma - 30.0), 0.1 * 30.0);
  ModelRequirements built{1.0, datasets::SensorKind::kCartesian, 30.0, std::nullopt};
  EXPECT_NO_THROW(check_model(built, regimes, "m.h5"));
  built.plot_sigma = 0.85 * sigma;
  EXPECT_THROW(check_model(built, regimes, "m.h5"), std::runtime_error);
  regimes.evaluated = datasets::parse_regime(text, "r.toml");  // a stated σ of 30 m: exact
  built.plot_sigma = 30.0 * (1.0 + 1e-3);
  EXPECT_THROW(check_model(built, regimes, "m.h5"), std::runtime_error);
  const CommonOptions common;
  EXPECT_FALSE(test_tracks(recorded, common).has_truth);
  CommonOptions truth_tracks;
  truth_tracks.truth_tracks = true;
  try {
    (void)test_tracks(recorded, truth_tracks);
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("--truth-tracks: no test track of regime 'r'"),
              std::string::npos)
        << error.what();
  }
}

TEST(PlotMetrics, WithoutTruthTheTrackerChoiceOrdersByItsOwnScore) {
  RankedFilter base, low, high;
  base.name = "baseline";
  base.baseline = true;
  base.score = 10.0;
  low.name = "low";
  low.score = 9.0;
  low.zeta_v = 100.0;  // a large second criterion does not reorder
  low.versus_baseline_p = {-1.0, -1.5, -0.5};
  low.versus_baseline_v = {-0.1, -0.2, 0.05};
  high.name = "high";
  high.score = 9.5;
  high.versus_baseline_p = {-0.5, -0.8, -0.2};
  high.versus_baseline_v = {-0.1, -0.2, 0.05};
  for (RankedFilter* f : {&base, &low, &high}) f->criteria = {"predictive NLL", "innovation RMS"};
  const std::vector<RankedFilter> filters{base, high, low};
  const TrackerChoice choice = choose_tracker(filters);
  EXPECT_EQ(choice.winner, 2U);
  EXPECT_EQ(choice.order, (std::vector<std::size_t>{2, 1, 0}));
  EXPECT_NE(choice.reason.find("predictive NLL"), std::string::npos) << choice.reason;
}

}  // namespace
}  // namespace imm::evaluation
