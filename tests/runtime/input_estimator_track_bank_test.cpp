// SPDX-License-Identifier: Apache-2.0
// The input-estimator bank against the one-track filter (make_mlp_input_estimator_filter):
// statuses, estimates and input estimates to the bit over random models and the shipped ones,
// tracks independent of their neighbours to the bit, refused plots leaving a track exactly as it
// was, and what it refuses.
#include "imm/tracking/input_estimator_track_bank.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/math/chi_square.hpp"
#include "testing/axis_lane_bank_checks.hpp"

namespace imm {
namespace {

// A random 2-h-1 or 2-h1-h2-1 network (sigmoid hidden layers, a sigmoid or linear output) with
// random features' standardization, bias, sign and input variance, at a random T, q and R.
MlpInputEstimatorModel random_model(std::mt19937_64& rng, int trial) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  auto random_layer = [&](int outputs, int inputs, Activation activation) {
    MlpLayer layer;
    layer.weights = Eigen::MatrixXd::NullaryExpr(outputs, inputs, [&] { return 2.0 * unit(rng); });
    layer.bias = Eigen::VectorXd::NullaryExpr(outputs, [&] { return unit(rng); });
    layer.activation = activation;
    return layer;
  };
  std::vector<MlpLayer> layers;
  const int h1 = 3 + trial % 9;
  layers.push_back(random_layer(h1, 2, Activation::kSigmoid));
  int last = h1;
  if (trial % 2 == 0) {
    layers.push_back(random_layer(10, h1, Activation::kSigmoid));
    last = 10;
  }
  layers.push_back(
      random_layer(1, last, trial % 3 == 0 ? Activation::kLinear : Activation::kSigmoid));
  MlpInputEstimatorModel model;
  model.network = Mlp(std::move(layers), 5.0 + 10.0 * (unit(rng) + 1.0));
  model.input_mean = Eigen::Vector2d(1.0 + 0.5 * unit(rng), 0.3 * unit(rng));
  model.input_scale = Eigen::Vector2d(0.5 + std::abs(unit(rng)), 1.0 + std::abs(unit(rng)));
  model.output_bias = 2.0 * (unit(rng) + 1.0);
  model.sign = trial % 2 == 0 ? InputSign::kInnovation : InputSign::kPositive;
  model.input_variance = trial % 3 == 1 ? 0.0 : 4.0 * (unit(rng) + 1.0);
  model.settings.sample_period = 0.5 + (unit(rng) + 1.0);
  model.settings.process_noise = 0.1 + (unit(rng) + 1.0);
  model.settings.measurement_variance = 20.0 + 40.0 * (unit(rng) + 1.0);
  return model;
}

GaussianState<4> bank_start_of(int track) {
  GaussianState<4> s;
  s.mean << 100.0 + track, 3.0, -40.0 + 5.0 * track, -2.0;
  s.covariance = Eigen::Vector4d(60.0, 20.0, 60.0, 20.0).asDiagonal();
  s.covariance(0, 1) = s.covariance(1, 0) = 10.0;
  s.covariance(2, 3) = s.covariance(3, 2) = -5.0;
  return s;
}

// Plots of track t at scan k: a target that turns hard now and then, with noise, a NaN or an
// out-of-range plot now and then.
Eigen::Vector2d plot_of(int track, int k, std::mt19937_64& rng) {
  std::normal_distribution<double> noise(0.0, 6.0);
  const double time = k;
  const int leg = k / 25;  // odd legs turn
  const double turn = leg % 2 == 1 ? 0.5 * std::pow(time - 25.0 * leg, 2) : 0.0;
  Eigen::Vector2d z(100.0 + track + 3.0 * time + turn * (1 + track % 3),
                    -40.0 + 5.0 * track - 2.0 * time - 0.4 * turn);
  z += Eigen::Vector2d(noise(rng), noise(rng));
  if ((k + track) % 29 == 3) z.y() = std::numeric_limits<double>::quiet_NaN();
  if ((k * 7 + track) % 53 == 11) z.x() = 1e300;
  return z;
}

// Every track of the bank beside its own one-track filter, scan by scan: both run the one scan
// (input_estimator_step.hpp), a lane of a block and a block of one lane, so the statuses, the
// estimates and the input estimates agree to the bit. Returns the refusals.
int expect_equals_one_track_filters(const MlpInputEstimatorModel& model, int scans,
                                    std::mt19937_64& rng, const std::string& name) {
  constexpr int kTracks = 13;  // three whole blocks of four tracks and one track more
  InputEstimatorTrackBank bank(model, kTracks);
  auto single =
      testing::one_track_filters(kTracks, [&] { return make_mlp_input_estimator_filter(model); });
  return testing::follow_one_track_filters(
      bank, single, name, 0, scans - 1, bank_start_of,
      [&](int t, int k) { return plot_of(t, k, rng); },
      [&](std::size_t t, const std::string& at) {
        SCOPED_TRACE(at);
        const GaussianState<4> reference = testing::two_axis_estimate(*single[t]);
        const GaussianState<4> estimate = bank.estimate(t);
        testing::expect_same_bits(estimate.mean, reference.mean);
        testing::expect_same_bits(estimate.covariance, reference.covariance);
        const auto input = [&](int axis) {
          return dynamic_cast<const MlpInputEstimatorAxis&>(single[t]->axis(axis))
              .filter()
              .acceleration();
        };
        testing::expect_same_bits(bank.acceleration(t), Eigen::Vector2d(input(0), input(1)));
      });
}

TEST(InputEstimatorTrackBank, EqualsTheOneTrackFilterToTheBit) {
  std::mt19937_64 rng(26112026);
  int refused = 0;
  for (int trial = 0; trial < 8; ++trial) {
    refused += expect_equals_one_track_filters(random_model(rng, trial), 150, rng,
                                               "trial " + std::to_string(trial));
    if (HasFailure()) return;
  }
  EXPECT_GT(refused, 100);  // the NaN and out-of-range plots were refused, by both
}

TEST(InputEstimatorTrackBank, EqualsTheOneTrackFilterWithTheShippedModels) {
  std::mt19937_64 rng(5);
  for (const char* name : {"mlp_input_estimator.h5", "mlp_input_estimator_ground_vehicle.h5"}) {
    expect_equals_one_track_filters(io::read_mlp_input_estimator(std::string("models/") + name),
                                    150, rng, name);
  }
}

// The input estimates of track t of `a` and track u of `b`, to the bit.
void expect_same_input(const InputEstimatorTrackBank& a, std::size_t t,
                       const InputEstimatorTrackBank& b, std::size_t u) {
  testing::expect_same_bits(a.acceleration(t), b.acceleration(u));
}

TEST(InputEstimatorTrackBank, ATracksResultDoesNotDependOnItsNeighboursToTheBit) {
  std::mt19937_64 rng(7);
  const MlpInputEstimatorModel model = random_model(rng, 4);
  testing::expect_tracks_independent_of_their_neighbours(
      11, 80, [&](std::size_t n) { return InputEstimatorTrackBank(model, n); }, bank_start_of,
      [&](int t, int k) { return plot_of(t, k, rng); }, expect_same_input);
}

// Blocks of 16 lanes (where the AVX-512 clone runs) and of 8 give the same bits: both run here
// whatever the CPU; 13 tracks are one whole block of 16 lanes and a partial one.
TEST(InputEstimatorTrackBank, TheWideAndNarrowBlocksGiveTheSameBits) {
  std::mt19937_64 rng(19);
  const MlpInputEstimatorModel model = random_model(rng, 2);
  testing::expect_wide_blocks_as_narrow_ones(
      13, 80, [&](std::size_t n, bool wide) { return InputEstimatorTrackBank(model, n, wide); },
      bank_start_of, [&](int t, int k) { return plot_of(t, k, rng); }, expect_same_input);
}

TEST(InputEstimatorTrackBank, ARefusedPlotLeavesTheTrackExactlyAsItWasAndLaterTracksUntouched) {
  std::mt19937_64 rng(11);
  const MlpInputEstimatorModel model = random_model(rng, 2);
  InputEstimatorTrackBank bank(model, 6);
  for (std::size_t t = 0; t < 6; ++t) bank.initialize(t, bank_start_of(static_cast<int>(t)));
  std::vector<Eigen::Vector2d> plots{{102.0, -41.0}, {105.0, -33.0}, {104.0, -31.0}};
  std::vector<StepStatus> status(3);
  for (int k = 0; k < 12; ++k) {  // some input estimate and windows to keep
    for (auto& z : plots) z += Eigen::Vector2d(3.0 + 0.5 * k, -2.0);
    bank.step(plots, status);
  }
  plots[1].y() = std::numeric_limits<double>::infinity();
  testing::expect_refused_plot_keeps_the_track(bank, plots, 4, expect_same_input);
  // The windows did not move either: the next scans equal a bank that never saw the bad plot.
  InputEstimatorTrackBank twin(model, 1);
  twin.initialize(0, bank_start_of(1));
  std::vector<Eigen::Vector2d> replay{{105.0, -33.0}};
  std::vector<StepStatus> one(1);
  for (int k = 0; k < 12; ++k) {
    replay[0] += Eigen::Vector2d(3.0 + 0.5 * k, -2.0);
    twin.step(replay, one);
  }
  plots[1] = replay[0] + Eigen::Vector2d(9.0, -2.0);
  replay[0] = plots[1];
  bank.step(plots, status);
  twin.step(replay, one);
  EXPECT_EQ(bank.estimate(1).mean, twin.estimate(0).mean);
  EXPECT_EQ(bank.acceleration(1), twin.acceleration(0));
}

// The gating matrix of tracks followed for `scans` scans beside their one-track filters: every
// entry is the one-track filter's answer after predict() (−∞ past the gate by its
// candidate_distance, else its candidate_log_likelihood) to the bit, and asking changes no track
// (the next steps equal the one-track filters' to the bit).
void expect_gating_as_the_one_track_filters(const MlpInputEstimatorModel& model, int scans,
                                            std::mt19937_64& rng, const std::string& name) {
  constexpr int kTracks = 13;
  InputEstimatorTrackBank bank(model, kTracks);
  auto single =
      testing::one_track_filters(kTracks, [&] { return make_mlp_input_estimator_filter(model); });
  testing::expect_gating_without_changing_a_track(
      bank, single, name, 0, scans - 1, bank_start_of,
      [&](int t, int k) { return plot_of(t, k, rng); },
      [&](std::size_t t, const std::string& at) {
        SCOPED_TRACE(at);
        const GaussianState<4> reference = testing::two_axis_estimate(*single[t]);
        testing::expect_same_bits(bank.estimate(t).mean, reference.mean);
        testing::expect_same_bits(bank.estimate(t).covariance, reference.covariance);
      },
      0.0, 2);
}

// A plot under a started track's prediction scores the closed form log N(z; ẑ, S) of the
// one-track filter's predicted plot (diagonal S: independent axes), here 1σ and −0.5σ away.
TEST(InputEstimatorTrackBank, ACandidateScoresTheClosedFormOfItsPredictedPlot) {
  std::mt19937_64 rng(12);
  for (int trial = 0; trial < 3; ++trial) {
    const MlpInputEstimatorModel model = random_model(rng, trial);
    InputEstimatorTrackBank bank(model, 2);
    auto single = make_mlp_input_estimator_filter(model);
    for (std::size_t t = 0; t < 2; ++t) bank.initialize(t, bank_start_of(static_cast<int>(t)));
    single->initialize(bank_start_of(1).mean, bank_start_of(1).covariance);
    ASSERT_EQ(single->predict(), StepStatus::kOk);
    Eigen::Vector2d z_hat;
    Eigen::Matrix2d S;
    ASSERT_TRUE(single->predicted_plot(z_hat, S));
    const Eigen::Vector2d sigma = S.diagonal().cwiseSqrt();
    const std::vector<Eigen::Vector2d> at{z_hat + Eigen::Vector2d(sigma.x(), -0.5 * sigma.y())};
    Eigen::MatrixXd out(2, 1);
    bank.candidate_log_likelihoods(at, std::numeric_limits<double>::infinity(), out);
    const double closed =
        -std::log(2.0 * std::numbers::pi) - 0.5 * std::log(S(0, 0) * S(1, 1)) - 0.5 * (1.0 + 0.25);
    EXPECT_NEAR(out(1, 0), closed, 1e-12 * std::abs(closed)) << trial;
  }
}

TEST(InputEstimatorTrackBank, ScoresCandidatePlotsAsTheOneTrackFilterWithoutChangingATrack) {
  std::mt19937_64 rng(3122026);
  for (int trial = 0; trial < 6; ++trial) {
    expect_gating_as_the_one_track_filters(random_model(rng, trial), 40, rng,
                                           "trial " + std::to_string(trial));
    if (HasFailure()) return;
  }
  for (const char* name : {"mlp_input_estimator.h5", "mlp_input_estimator_ground_vehicle.h5"}) {
    expect_gating_as_the_one_track_filters(
        io::read_mlp_input_estimator(std::string("models/") + name), 60, rng, name);
  }
}

// Tracks past the first few hundred (the matrix is filled in chunks of tracks) and a submatrix of
// a larger matrix (a column stride other than the rows) give the one-track filters' answers too.
TEST(InputEstimatorTrackBank, ScoresEveryTrackOfALargeBankIntoAnyColumnStride) {
  std::mt19937_64 rng(8);
  const MlpInputEstimatorModel model = random_model(rng, 3);
  constexpr int kTracks = 600;
  InputEstimatorTrackBank bank(model, kTracks);
  std::vector<std::unique_ptr<TwoAxisFilter>> single;
  std::vector<Eigen::Vector2d> plots;
  for (int t = 0; t < kTracks; ++t) {
    bank.initialize(static_cast<std::size_t>(t), bank_start_of(t));
    single.push_back(make_mlp_input_estimator_filter(model));
    single.back()->initialize(bank_start_of(t).mean, bank_start_of(t).covariance);
    ASSERT_EQ(single.back()->predict(), StepStatus::kOk);
    if (t % 150 == 149) plots.push_back(bank_start_of(t).mean(Eigen::seq(0, 2, 2)));
  }
  Eigen::MatrixXd larger(kTracks + 7, static_cast<Eigen::Index>(plots.size()) + 1);
  auto out = larger.block(0, 1, kTracks, static_cast<Eigen::Index>(plots.size()));
  bank.candidate_log_likelihoods(plots, chi_square_quantile(0.99, 2), out);
  int inside = 0;
  for (int t = 0; t < kTracks; ++t) {
    for (std::size_t q = 0; q < plots.size(); ++q) {
      const double entry = out(t, static_cast<Eigen::Index>(q));
      if (single[static_cast<std::size_t>(t)]->candidate_distance(plots[q]) >
          chi_square_quantile(0.99, 2)) {
        EXPECT_EQ(entry, -std::numeric_limits<double>::infinity()) << t << " " << q;
      } else {
        EXPECT_EQ(entry, single[static_cast<std::size_t>(t)]->candidate_log_likelihood(plots[q]))
            << t << " " << q;
        ++inside;
      }
    }
  }
  EXPECT_GE(inside, static_cast<int>(plots.size()));  // each plot at least by its own track
}

TEST(InputEstimatorTrackBank, RefusesWhatItCannotRun) {
  std::mt19937_64 rng(3);
  const MlpInputEstimatorModel model = random_model(rng, 1);
  EXPECT_EQ(testing::refused_field<InputEstimatorTrackBank>(model, 0), "capacity");
  EXPECT_EQ(testing::refused_field<InputEstimatorTrackBank>(model, (std::size_t{1} << 26U) + 1),
            "capacity");
  MlpInputEstimatorModel bad = model;
  bad.settings.measurement_variance = -1.0;
  EXPECT_EQ(testing::refused_field<InputEstimatorTrackBank>(bad, 4), "measurement_variance");
  bad = model;
  bad.input_variance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(testing::refused_field<InputEstimatorTrackBank>(bad, 4), "input_variance");
  InputEstimatorTrackBank bank(model, 3);
  testing::expect_refused_misuse(bank, bank_start_of(0), Eigen::Vector2d(1.0, 2.0));
  testing::expect_refused_gating(bank);
}

}  // namespace
}  // namespace imm
