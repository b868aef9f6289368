// SPDX-License-Identifier: Apache-2.0
// imm-train fcm: config validation, thread-count independence of the scoring, the λ = 0 member
// of the family equal to the constant-q IMM, and a small end-to-end fit.

#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>

#include "imm/datasets/track.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/fcm/fcm_trainer.hpp"
#include "testing/config_error.hpp"
#include "testing/regime_files.hpp"
#include "testing/temp_dir.hpp"

namespace imm::trainer {
namespace {

std::string fcm_config_error(const std::string& text) {
  return testing::config_error_key(
      "regime = \"configs/regimes/paper/fcm_imm_training.toml\"\n" + text,
      [](const auto& path) { return fcm::load_fcm_config(path); });
}

TEST(FcmConfig, InvalidValuesAreNamed) {
  EXPECT_EQ(fcm_config_error(""), "");
  EXPECT_EQ(fcm_config_error("[tuning]\ncompensation_gain = [0.0, 1.5]\n"),
            "tuning.compensation_gain");
  EXPECT_EQ(fcm_config_error("[filter]\nmembership_scale = \"loose\"\n"),
            "filter.membership_scale");
  EXPECT_EQ(fcm_config_error("[filter]\nfuzzifier = 1.0\n"), "filter.fuzzifier");
  EXPECT_EQ(fcm_config_error("[filter]\nmodes = 2\nprocess_noise = [1.0, 2.0, 3.0]\n"),
            "filter.process_noise");
  EXPECT_EQ(fcm_config_error("[filter]\nwindow = 500\n"), "filter.window");
  EXPECT_EQ(fcm_config_error("[tuning]\nwindows = [8, 2]\n"), "tuning.windows");
  EXPECT_EQ(fcm_config_error("[training]\nperiods = [1, 4]\n"), "training");  // now the regime's
  EXPECT_EQ(fcm_config_error("[gate]\nmax_validation_ratio = \"low\"\n"),
            "gate.max_validation_ratio");
  const auto shipped = fcm::load_fcm_config("configs/fcm_imm.toml");
  EXPECT_EQ(shipped.filter.measurement_sigma, 100.0);
  EXPECT_EQ(shipped.filter.mode_count(), 3);
  EXPECT_EQ(shipped.filter.scale, MembershipScale::kInnovation);
}

fcm::FcmTrainingConfig small_config() {
  const testing::TempDir dir;
  auto config =
      fcm::load_fcm_config("configs/fcm_imm.toml",
                           testing::write_preset_variant(dir, "fcm_imm_training",
                                                         {{"scans = 300", "scans = 150"},
                                                          {"periods = [1, 4]", "periods = [1, 2]"},
                                                          {"training = 16", "training = 4"},
                                                          {"validation = 8", "validation = 2"}}));
  config.tuning.windows = {8};
  config.tuning.max_evaluations = 12;
  return config;
}

TEST(FcmTraining, TrajectoriesAreSeededDisjointAndVaried) {
  const auto config = small_config();
  const auto a = datasets::draw_split(config.regime, datasets::Split::kTraining, 0);
  const auto b = datasets::draw_split(config.regime, datasets::Split::kTraining, 0);
  const auto v = datasets::draw_split(config.regime, datasets::Split::kValidation, 0);
  ASSERT_EQ(a.tracks.size(), 4u);
  ASSERT_EQ(v.tracks.size(), 2u);
  EXPECT_EQ(a.tracks[2].plots, b.tracks[2].plots);
  EXPECT_NE(a.tracks[0].truth.row(0), a.tracks[1].truth.row(0));
  EXPECT_NE(a.tracks[0].truth.row(0), v.tracks[0].truth.row(0));
  const double range = std::hypot(a.tracks[1].truth(0, 0), a.tracks[1].truth(0, 3));
  EXPECT_GE(range, 250e3);
  EXPECT_LE(range, 400e3);
}

TEST(FcmTraining, ScoreIsIndependentOfTheThreadCount) {
  const auto config = small_config();
  const auto data = datasets::draw_split(config.regime, datasets::Split::kTraining, 0);
  FcmImmSpec spec = config.filter;
  spec.compensation_gain = 0.3;
  auto make = [&] { return make_fcm_imm_filter(spec); };
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const auto one = fcm::score_filter(make, data, 100.0);
  omp_set_num_threads(2);
  const auto two = fcm::score_filter(make, data, 100.0);
  omp_set_num_threads(threads);
  EXPECT_EQ(one.objective, two.objective);
  EXPECT_EQ(one.position_rmse, two.position_rmse);
  EXPECT_GT(one.position_rmse, 0.0);
}

// Without truth the objective is the excess NLL per plot: the two-axis filter's own
// −log p(z | Z^(k−1)), averaged over the scored scans, less the plots' entropy log(2πeσ²) (two
// axes); recomputed here by stepping the filter by hand. The truth is NaN: nothing reads it.
TEST(FcmTraining, WithoutTruthTheObjectiveIsTheFiltersExcessNll) {
  const auto config = small_config();
  auto data = datasets::draw_split(config.regime, datasets::Split::kTraining, 0);
  data.has_truth = false;
  for (auto& track : data.tracks) track.truth.setConstant(std::nan(""));
  FcmImmSpec spec = config.filter;
  spec.compensation_gain = 0.3;
  auto make = [&] { return make_fcm_imm_filter(spec); };
  const auto score = fcm::score_filter(make, data, 100.0);
  double nll = 0.0;
  long plots = 0;
  const double T = data.sample_period, r = 100.0 * 100.0;
  for (const auto& track : data.tracks) {
    auto filter = make();
    Eigen::VectorXd mean(4);
    Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(4, 4);
    for (int axis = 0; axis < 2; ++axis) {
      const double z0 = track.plots(0, axis), z1 = track.plots(1, axis);
      mean.segment<2>(2 * axis) << z1, (z1 - z0) / T;
      covariance.block<2, 2>(2 * axis, 2 * axis) << r, r / T, r / T, 2.0 * r / (T * T);
    }
    filter->initialize(mean, covariance);
    for (Eigen::Index k = 2; k < track.plots.rows(); ++k) {
      ASSERT_EQ(filter->step(track.plots.row(k).transpose()), StepStatus::kOk);
      nll -= filter->log_predictive_likelihood();
      ++plots;
    }
  }
  const double expected =
      nll / static_cast<double>(plots) - std::log(2.0 * std::numbers::pi * std::numbers::e * r);
  EXPECT_NEAR(score.objective, expected, 1e-12 * std::abs(nll / static_cast<double>(plots)));
  EXPECT_TRUE(std::isnan(score.position_rmse));
  EXPECT_GT(score.objective, 0.0);  // a filter cannot know the positions better than the plots
}

TEST(FcmTraining, LambdaZeroIsTheConstantNoiseImm) {
  const auto config = small_config();
  const auto data = datasets::draw_split(config.regime, datasets::Split::kTraining, 0);
  AxisCvImmSpec imm;
  imm.settings.sample_period = 1.0;
  imm.settings.sample_period = 1.0;
  imm.settings.measurement_sigma = 100.0;
  imm.settings.transition_stay = 0.93;
  imm.settings.initial_first_probability = config.initial_first_probability;
  imm.process_noise = {0.5, 80.0, 3000.0};
  const FcmImmSpec spec = fcm::fcm_spec_from(config, imm);
  EXPECT_EQ(spec.compensation_gain, 0.0);
  const auto a = fcm::score_filter([&] { return make_axis_cv_imm_filter(imm); }, data, 100.0);
  const auto b = fcm::score_filter([&] { return make_fcm_imm_filter(spec); }, data, 100.0);
  EXPECT_NEAR(a.objective, b.objective, 1e-9 * a.objective);
}

TEST(FcmTraining, FitWritesAModelNoWorseThanItsStartAndIsReproducible) {
  const testing::TempDir dir;
  const auto config = small_config();
  const auto first = fcm::train_fcm(config, dir / "a.h5");
  const auto second = fcm::train_fcm(config, dir / "b.h5");
  ASSERT_TRUE(first.gate_passed);
  // Never worse on the training split than the tuned IMM it starts from; with its learned part
  // off it is that IMM (λ = 0), and the metrics say so.
  EXPECT_LE(first.training.objective, first.imm_training.objective + 1e-12);
  EXPECT_EQ(first.learned_part_on, first.spec.compensation_gain > 0.0);
  EXPECT_EQ(first.spec.process_noise, second.spec.process_noise);
  EXPECT_EQ(first.spec.compensation_gain, second.spec.compensation_gain);
  EXPECT_EQ(first.validation.objective, second.validation.objective);
  const FcmImmSpec back = io::read_fcm_imm(dir / "a.h5");
  EXPECT_EQ(back.process_noise, first.spec.process_noise);
  EXPECT_EQ(back.window, 8);
  ASSERT_EQ(back.mean_memberships.rows(), 3);
  EXPECT_NEAR(back.mean_memberships.row(2).sum(), 1.0, 1e-12);
  const auto metrics = nlohmann::json::parse(testing::slurp_text(dir / "a.metrics.json"));
  EXPECT_TRUE(metrics["gate"]["passed"].get<bool>());
  EXPECT_GT(metrics["validation"]["pos_rmse"].get<double>(), 0.0);
  EXPECT_EQ(metrics["windows"].size(), 1u);
  EXPECT_EQ(metrics["learned_part_on"].get<bool>(), first.learned_part_on);
}

TEST(FcmTraining, FailedGateWritesNoModel) {
  const testing::TempDir dir;
  auto config = small_config();
  config.max_validation_ratio = 0.01;
  const auto result = fcm::train_fcm(config, dir / "f.h5");
  EXPECT_FALSE(result.gate_passed);
  EXPECT_FALSE(std::filesystem::exists(dir / "f.h5"));
  const auto metrics = nlohmann::json::parse(testing::slurp_text(dir / "f.metrics.json"));
  EXPECT_FALSE(metrics["gate"]["passed"].get<bool>());
}

}  // namespace
}  // namespace imm::trainer
