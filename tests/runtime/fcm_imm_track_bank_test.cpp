// SPDX-License-Identifier: Apache-2.0
// The FCM-IMM's bank against the one-track filter (make_fcm_imm_filter): statuses, estimates and
// μ to rounding over random specs (1–4 modes, fuzzifiers 2, 4 and 2.5, both membership scales,
// the constant-membership ablation) and the shipped models, tracks independent of their
// neighbours to the bit, refused plots leaving a track exactly as it was, and what it refuses.
#include "imm/tracking/fcm_imm_track_bank.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "testing/axis_lane_bank_checks.hpp"

namespace imm {
namespace {

FcmImmSpec random_spec(std::mt19937_64& rng, int trial) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  FcmImmSpec spec;
  const int n = 1 + trial % 4;
  spec.sample_period = 0.5 + 1.5 * unit(rng);
  spec.measurement_sigma = 5.0 + 20.0 * unit(rng);
  spec.process_noise.clear();
  double q = 0.1 + unit(rng);
  for (int j = 0; j < n; ++j, q *= 5.0 + 20.0 * unit(rng)) spec.process_noise.push_back(q);
  spec.transition = FcmImmSpec::switching_transition(n, 0.8 + 0.19 * unit(rng));
  Eigen::VectorXd mu0 = Eigen::VectorXd::NullaryExpr(n, [&] { return 0.1 + unit(rng); });
  spec.initial_probabilities = mu0 / mu0.sum();
  constexpr std::array kFuzzifiers = {2.0, 4.0, 2.5};
  spec.clustering.fuzzifier = kFuzzifiers[static_cast<std::size_t>(trial % 3)];
  spec.window = 3 + static_cast<int>(17.0 * unit(rng));
  spec.scale = trial % 5 == 2 ? MembershipScale::kSeed : MembershipScale::kInnovation;
  spec.separation = 1.0 + 3.0 * unit(rng);
  spec.compensation_gain = 0.05 + 0.5 * unit(rng);
  spec.compensate_lowest = trial % 2 == 0;
  if (trial % 7 == 5) {
    spec.constant_memberships = true;
    spec.mean_memberships = Eigen::MatrixXd(n, 3);
    for (int j = 0; j < n; ++j) {
      const Eigen::Vector3d row(unit(rng), 1.0 + unit(rng), unit(rng));
      spec.mean_memberships.row(j) = row.transpose() / row.sum();
    }
  }
  return spec;
}

// Track t's start, in units of `scale` (the plots' noise is 10 of them).
GaussianState<4> start_of(int track, double scale = 1.0) {
  GaussianState<4> s;
  s.mean << 100.0 + track, 30.0, -40.0 + 5.0 * track, -20.0;
  s.mean *= scale;
  s.covariance = Eigen::Vector4d(400.0, 100.0, 400.0, 100.0).asDiagonal();
  s.covariance(0, 1) = s.covariance(1, 0) = 20.0;
  s.covariance(2, 3) = s.covariance(3, 2) = -10.0;
  s.covariance *= scale * scale;
  return s;
}

// Plots of track t at scan k, in units of `scale`: a target that turns hard now and then, with
// noise, a NaN or an out-of-range plot now and then.
Eigen::Vector2d plot_of(int track, int k, std::mt19937_64& rng, double scale = 1.0) {
  std::normal_distribution<double> noise(0.0, 10.0);
  const double time = k;
  const int leg = k / 25;  // odd legs turn
  const double turn = leg % 2 == 1 ? 2.0 * std::pow(time - 25.0 * leg, 2) : 0.0;
  Eigen::Vector2d z(100.0 + track + 30.0 * time + turn * (1 + track % 3),
                    -40.0 + 5.0 * track - 20.0 * time - 0.4 * turn);
  z += Eigen::Vector2d(noise(rng), noise(rng));
  z *= scale;
  if ((k + track) % 29 == 3) z.y() = std::numeric_limits<double>::quiet_NaN();
  if ((k * 7 + track) % 53 == 11) z.x() = 1e300;
  return z;
}

// Every track of the bank beside its own one-track filter, scan by scan, the plots' noise 10
// units of `scale`; returns the refusals.
int expect_equals_one_track_filters(const FcmImmSpec& spec, int scans, std::mt19937_64& rng,
                                    const std::string& name, double scale = 1.0) {
  constexpr int kTracks = 13;  // three whole blocks of four tracks and one track more
  FcmImmTrackBank bank(spec, kTracks);
  auto single = testing::one_track_filters(kTracks, [&] { return make_fcm_imm_filter(spec); });
  return testing::follow_one_track_filters(
      bank, single, name, 1, scans, [&](int t) { return start_of(t, scale); },
      [&](int t, int k) { return plot_of(t, k, rng, scale); },
      [&](std::size_t t, const std::string& at) {
        testing::expect_two_axis_close(bank, t, *single[t], at);
      });
}

TEST(FcmImmTrackBank, EqualsTheOneTrackFilterToRounding) {
  std::mt19937_64 rng(26112026);
  int refused = 0;
  for (int trial = 0; trial < 14; ++trial) {
    const FcmImmSpec spec = random_spec(rng, trial);
    refused += expect_equals_one_track_filters(spec, 120, rng, "trial " + std::to_string(trial));
    if (HasFailure()) return;
  }
  EXPECT_GT(refused, 100);  // the NaN and out-of-range plots were refused, by both
}

TEST(FcmImmTrackBank, EqualsTheOneTrackFilterWithTheShippedModels) {
  std::mt19937_64 rng(5);
  for (const char* name : {"fcm_imm.h5", "fcm_imm_agile_air.h5", "fcm_imm_ground_vehicle.h5"}) {
    const FcmImmSpec spec = io::read_fcm_imm(std::string("models/") + name);
    // Plot noise of the model's σ.
    expect_equals_one_track_filters(spec, 150, rng, name, spec.measurement_sigma / 10.0);
  }
}

// The gating matrix of tracks followed for `scans` scans beside their one-track filters equals
// the filters' candidate questions after predict() (trial updates: the window's clustering reads
// the plot's error) to 1e-12 relative, and asking changes no track or window: the next steps
// still follow the filters'.
void expect_gating_as_the_one_track_filters(const FcmImmSpec& spec, int scans, std::mt19937_64& rng,
                                            const std::string& name, double scale = 1.0) {
  constexpr int kTracks = 13;
  FcmImmTrackBank bank(spec, kTracks);
  auto single = testing::one_track_filters(kTracks, [&] { return make_fcm_imm_filter(spec); });
  testing::expect_gating_without_changing_a_track(
      bank, single, name, 1, scans, [&](int t) { return start_of(t, scale); },
      [&](int t, int k) { return plot_of(t, k, rng, scale); },
      [&](std::size_t t, const std::string& at) {
        testing::expect_two_axis_close(bank, t, *single[t], at);
      },
      1e-12, 3);  // three scans: the windows took nothing from the trials
}

TEST(FcmImmTrackBank, ScoresCandidatePlotsAsTheOneTrackFilterWithoutChangingATrack) {
  std::mt19937_64 rng(3122026);
  for (int trial = 0; trial < 8; ++trial) {
    expect_gating_as_the_one_track_filters(random_spec(rng, trial), 40, rng,
                                           "trial " + std::to_string(trial));
    if (HasFailure()) return;
  }
  for (const char* name : {"fcm_imm.h5", "fcm_imm_agile_air.h5"}) {
    const FcmImmSpec spec = io::read_fcm_imm(std::string("models/") + name);
    expect_gating_as_the_one_track_filters(spec, 60, rng, name, spec.measurement_sigma / 10.0);
  }
}

TEST(FcmImmTrackBank, ATracksResultDoesNotDependOnItsNeighboursToTheBit) {
  std::mt19937_64 specs(7);
  const FcmImmSpec spec = random_spec(specs, 1);
  std::mt19937_64 rng(8);
  testing::expect_tracks_independent_of_their_neighbours(
      11, 80, [&](std::size_t n) { return FcmImmTrackBank(spec, n); },
      [](int t) { return start_of(t); }, [&](int t, int k) { return plot_of(t, k + 1, rng); },
      testing::expect_same_mu<FcmImmTrackBank>);
}

TEST(FcmImmTrackBank, ARefusedPlotLeavesTheTrackExactlyAsItWasWindowsIncluded) {
  std::mt19937_64 specs(11);
  const FcmImmSpec spec = random_spec(specs, 3);
  FcmImmTrackBank bank(spec, 6);
  for (std::size_t t = 0; t < 6; ++t) bank.initialize(t, start_of(static_cast<int>(t)));
  std::vector<Eigen::Vector2d> plots{{130.0, -60.0}, {131.0, -55.0}, {132.0, -51.0}};
  std::vector<StepStatus> status(3);
  auto advance = [](std::vector<Eigen::Vector2d>& z, int k) {
    for (auto& p : z) p += Eigen::Vector2d(30.0 + 3.0 * k, -20.0);
  };
  for (int k = 0; k < 12; ++k) {
    advance(plots, k);
    bank.step(plots, status);
  }
  std::vector<Eigen::Vector2d> bad = plots;
  bad[1].y() = std::numeric_limits<double>::infinity();
  testing::expect_refused_plot_keeps_the_track(bank, bad, 4,
                                               testing::expect_same_mu<FcmImmTrackBank>);
  // The windows did not move either: the next scans equal a bank that never saw the bad plot.
  FcmImmTrackBank twin(spec, 1);
  twin.initialize(0, start_of(1));
  std::vector<Eigen::Vector2d> replay{{131.0, -55.0}};
  std::vector<StepStatus> one(1);
  for (int k = 0; k < 12; ++k) {
    advance(replay, k);
    twin.step(replay, one);
  }
  for (int k = 12; k < 20; ++k) {
    advance(plots, k);
    advance(replay, k);
    bank.step(plots, status);
    twin.step(replay, one);
    ASSERT_EQ(status[1], one[0]);
    testing::expect_same_bits(bank.estimate(1).mean, twin.estimate(0).mean);
    testing::expect_same_bits(bank.estimate(1).covariance, twin.estimate(0).covariance);
  }
}

TEST(FcmImmTrackBank, RefusesWhatItCannotRun) {
  FcmImmSpec spec;
  spec.sample_period = 1.0;
  EXPECT_EQ(testing::refused_field<FcmImmTrackBank>(spec, 0), "capacity");
  spec.transition = FcmImmSpec::switching_transition(3, 1.0);  // no switching at all
  EXPECT_EQ(testing::refused_field<FcmImmTrackBank>(spec, 4), "transition");
  spec = FcmImmSpec();
  spec.sample_period = 1.0;
  spec.window = 2;
  EXPECT_EQ(testing::refused_field<FcmImmTrackBank>(spec, 4), "window");
  spec = FcmImmSpec();
  spec.sample_period = 1.0;
  FcmImmTrackBank bank(spec, 3);
  GaussianState<4> bad = start_of(0);
  bad.mean(1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(testing::refused_field_of([&] { bank.initialize(0, bad); }), "initial_state");
  testing::expect_refused_misuse(bank, start_of(0), Eigen::Vector2d(1.0, 2.0));
  testing::expect_refused_gating(bank);
}

}  // namespace
}  // namespace imm
