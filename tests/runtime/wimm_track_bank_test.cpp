// SPDX-License-Identifier: Apache-2.0
// The weighted IMM's bank against the one-track WimmFilter: statuses, estimates, μ and the fusion
// flag to rounding over random specs of every fusion variant and both updates and the shipped
// models, tracks independent of their neighbours to the bit, refused plots leaving a track
// exactly as it was, and what it refuses.
#include "imm/tracking/wimm_track_bank.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/io/wimm_file.hpp"
#include "testing/axis_lane_bank_checks.hpp"

namespace imm {
namespace {

// A random spec; `trial` picks the fusion variant, the update and whether the threshold fuses on
// every scan, on none or in between.
WimmSpec random_spec(std::mt19937_64& rng, int trial) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  WimmSpec spec;
  spec.sample_period = 1.0 + 4.0 * unit(rng);
  spec.cv_process_noise = 0.1 + 10.0 * unit(rng);
  spec.singer_tau = 5.0 + 55.0 * unit(rng);
  spec.singer_sigma = 1.0 + 19.0 * unit(rng);
  spec.range_sigma = 10.0 + 90.0 * unit(rng);
  spec.azimuth_sigma = (0.1 + 0.9 * unit(rng)) * std::numbers::pi / 180.0;
  const double stay0 = 0.8 + 0.19 * unit(rng), stay1 = 0.8 + 0.19 * unit(rng);
  spec.transition << stay0, 1.0 - stay0, 1.0 - stay1, stay1;
  const double mu0 = trial % 4 == 3 ? 1.0 : unit(rng);  // one trial starts with μ_Singer = 0
  spec.initial_probabilities = Eigen::Vector2d(mu0, 1.0 - mu0);
  const int fuses = (trial / 3) % 3;  // on every scan, in between, on none
  spec.threshold = fuses == 0 ? 0.0 : (fuses == 1 ? 0.3 + 0.6 * unit(rng) : 1.0);
  spec.alpha = 0.2 + 0.8 * unit(rng);
  constexpr std::array kVariants = {FusionVariant::kNone, FusionVariant::kSeed,
                                    FusionVariant::kCorrelated};
  spec.fusion = kVariants[static_cast<std::size_t>(trial % 3)];
  spec.update = trial % 2 == 1 && spec.fusion != FusionVariant::kCorrelated
                    ? MeasurementUpdate::kConverted
                    : MeasurementUpdate::kExtended;
  spec.acceleration_variance = 1.0 + 30.0 * unit(rng);
  return spec;
}

// Track t's true position at time s: a target 20–90 km out weaving at up to 5.5 m/s² (period
// 120 s), faster for odd tracks; every fifth track flies straight across the south seam (azimuth
// ±π).
Eigen::Vector2d truth_of(int track, double s) {
  if (track % 5 == 0) return {-3000.0 + 150.0 * s + track, -40000.0 - 20.0 * s};
  const double w = (track % 2 == 1 ? 2.0 : 1.0) * std::numbers::pi / 60.0;
  const double amplitude = 5.5 / (w * w);
  return {20000.0 + 1000.0 * track - 180.0 * s + amplitude * std::sin(w * s),
          30000.0 + 2500.0 * track + 90.0 * s + amplitude * (std::cos(w * s) - 1.0)};
}

GaussianState<6> start_of(int track) {
  const Eigen::Vector2d p = truth_of(track, 0.0);
  const Eigen::Vector2d v = truth_of(track, 1.0) - p;
  GaussianState<6> s;
  s.mean << p.x() + 40.0, v.x(), 0.0, p.y() - 30.0, v.y(), 0.0;
  s.covariance =
      (Eigen::Matrix<double, 6, 1>() << 2e4, 400.0, 9.0, 2e4, 400.0, 9.0).finished().asDiagonal();
  s.covariance(0, 1) = s.covariance(1, 0) = 500.0;
  s.covariance(3, 4) = s.covariance(4, 3) = -300.0;
  s.covariance(0, 3) = s.covariance(3, 0) = 1000.0;
  return s;
}

// The polar plot of track t at scan k: noise, and a NaN or an out-of-range plot now and then.
Eigen::Vector2d plot_of(const WimmSpec& spec, int track, int k, std::mt19937_64& rng) {
  std::normal_distribution<double> noise(0.0, 1.0);
  const Eigen::Vector2d p = truth_of(track, k * spec.sample_period);
  Eigen::Vector2d z(std::hypot(p.x(), p.y()) + spec.range_sigma * noise(rng),
                    std::atan2(p.x(), p.y()) + spec.azimuth_sigma * noise(rng));
  z.y() = std::remainder(z.y(), 2.0 * std::numbers::pi);
  if ((k + track) % 29 == 3) z.y() = std::numeric_limits<double>::quiet_NaN();
  if ((k * 7 + track) % 53 == 11) z.x() = 1e300;
  return z;
}

// The bank's measurement and mode steps are the one-track filter's (wimm_step.hpp,
// position_kalman_step.hpp; their own tests compare lanes to the bit), so the two differ by the
// rounding of the IMM cycle around them (the bank's mixing and posterior by lane_exp and lane_log,
// which also moves θ̄ and the fusion's threshold test by an ulp): below 1e-11 here, within
// testing::expect_estimate_close's 1e-9; an error in the cycle shows many orders above.

// Track t's estimate and μ against its one-track filter's, to rounding.
void expect_close(const WimmTrackBank& bank, std::size_t t, const WimmFilter& filter,
                  const std::string& at) {
  const GaussianState<6>& reference = filter.estimate();
  testing::expect_estimate_close(bank.estimate(t), reference.mean, reference.covariance,
                                 bank.mode_probabilities(t), filter.mode_probabilities(), at);
}

// Every track of the bank beside its own one-track filter, scan by scan.
void expect_equals_one_track_filters(const WimmSpec& spec, int scans, std::mt19937_64& rng,
                                     const std::string& name, int& refused, int& fused) {
  constexpr int kTracks = 13;  // one whole block of eight tracks and a partial one
  WimmTrackBank bank(spec, kTracks);
  auto single =
      testing::one_track_filters(kTracks, [&] { return std::make_unique<WimmFilter>(spec); });
  refused += testing::follow_one_track_filters(
      bank, single, name, 1, scans, start_of,
      [&](int t, int k) { return plot_of(spec, t, k, rng); },
      [&](std::size_t t, const std::string& at) {
        expect_close(bank, t, *single[t], at);
        EXPECT_EQ(bank.fused(t), single[t]->fused()) << at;
        fused += bank.fused(t) ? 1 : 0;
      });
}

TEST(WimmTrackBank, EqualsTheOneTrackFilterToRounding) {
  std::mt19937_64 rng(26112026);
  int refused = 0, fused = 0;
  for (int trial = 0; trial < 12; ++trial) {
    const WimmSpec spec = random_spec(rng, trial);
    expect_equals_one_track_filters(spec, 150, rng,
                                    "trial " + std::to_string(trial) + " (" +
                                        std::string(to_string(spec.fusion)) + ", " +
                                        std::string(to_string(spec.update)) + ")",
                                    refused, fused);
    if (HasFailure()) return;
  }
  EXPECT_GT(refused, 100);  // the NaN and out-of-range plots were refused, by both
  EXPECT_GT(fused, 1000);   // and the fusion ran
}

// The NIS a step states (what a covariance calibration follows) is the one-track filter's
// last_step_nis in every configuration: where a track fused, the modes' innovations are rewritten
// into the plot's as WimmFilter::innovation does (the wrapped azimuth, the correlated fusion's
// scaling, the converted plot's difference). To rounding, as the estimates.
TEST(WimmTrackBank, StatesTheOneTrackFiltersNisInEveryConfiguration) {
  std::mt19937_64 rng(3122026);
  std::map<std::string, int> fused_steps;
  for (int trial = 0; trial < 12; ++trial) {
    const WimmSpec spec = random_spec(rng, trial);
    const std::string name =
        std::string(to_string(spec.fusion)) + ", " + std::string(to_string(spec.update));
    constexpr int kTracks = 13;
    WimmTrackBank bank(spec, kTracks);
    auto single =
        testing::one_track_filters(kTracks, [&] { return std::make_unique<WimmFilter>(spec); });
    for (int t = 0; t < kTracks; ++t) {
      bank.initialize(static_cast<std::size_t>(t), start_of(t));
      single[static_cast<std::size_t>(t)]->initialize(start_of(t).mean, start_of(t).covariance);
    }
    std::vector<Eigen::Vector2d> plots(kTracks);
    std::vector<StepStatus> status(kTracks);
    std::vector<double> nis(kTracks);
    for (int k = 1; k <= 60; ++k) {
      for (int t = 0; t < kTracks; ++t)
        plots[static_cast<std::size_t>(t)] = plot_of(spec, t, k, rng);
      bank.step(plots, status, nis);
      for (std::size_t t = 0; t < kTracks; ++t) {
        const std::string at = name + " scan " + std::to_string(k) + " track " + std::to_string(t);
        ASSERT_EQ(status[t], single[t]->step(plots[t])) << at;
        if (status[t] != StepStatus::kOk) {
          EXPECT_TRUE(std::isnan(nis[t])) << at;
          continue;
        }
        const auto reference = last_step_nis(*single[t]);
        ASSERT_TRUE(reference.has_value()) << at;
        EXPECT_NEAR(nis[t], *reference, 1e-8 * (1.0 + *reference)) << at;
        fused_steps[name] += single[t]->fused() ? 1 : 0;
      }
      if (HasFailure()) return;
    }
  }
  // Every rewriting ran.
  EXPECT_GT(fused_steps["seed, extended"], 100);
  EXPECT_GT(fused_steps["seed, converted"], 100);
  EXPECT_GT(fused_steps["correlated, extended"], 100);
}

TEST(WimmTrackBank, EqualsTheOneTrackFilterWithTheShippedModels) {
  std::mt19937_64 rng(5);
  int refused = 0, fused = 0;
  for (const char* name :
       {"wimm.h5", "wimm_air_surveillance.h5", "baseline_nimm_air_surveillance.h5"}) {
    expect_equals_one_track_filters(io::read_wimm(std::string("models/") + name), 150, rng, name,
                                    refused, fused);
  }
  EXPECT_GT(fused, 100);
}

// μ and whether the last step fused, of track t of `a` and track u of `b`, to the bit.
void expect_same_mu_and_fusion(const WimmTrackBank& a, std::size_t t, const WimmTrackBank& b,
                               std::size_t u) {
  testing::expect_same_mu(a, t, b, u);
  EXPECT_EQ(a.fused(t), b.fused(u));
}

TEST(WimmTrackBank, ATracksResultDoesNotDependOnItsNeighboursToTheBit) {
  std::mt19937_64 specs(7);
  const WimmSpec spec = random_spec(specs, 1);
  std::mt19937_64 rng(8);
  testing::expect_tracks_independent_of_their_neighbours(
      11, 80, [&](std::size_t n) { return WimmTrackBank(spec, n); }, start_of,
      [&](int t, int k) { return plot_of(spec, t, k + 1, rng); }, expect_same_mu_and_fusion);
}

TEST(WimmTrackBank, ARefusedPlotOrAFailedModeLeavesTheTrackExactlyAsItWas) {
  WimmSpec spec;
  spec.sample_period = 2.0;
  spec.threshold = 0.0;
  WimmTrackBank bank(spec, 5);
  for (std::size_t t = 0; t < 5; ++t) bank.initialize(t, start_of(static_cast<int>(t)));
  std::mt19937_64 rng(11);
  std::vector<Eigen::Vector2d> plots(3);
  std::vector<StepStatus> status(3);
  for (int k = 1; k <= 10; ++k) {
    for (int t = 0; t < 3; ++t) {
      const Eigen::Vector2d p = truth_of(t + 1, k * spec.sample_period);
      plots[static_cast<std::size_t>(t)] = {std::hypot(p.x(), p.y()), std::atan2(p.x(), p.y())};
    }
    bank.step(plots, status);
  }
  ASSERT_EQ(status, std::vector<StepStatus>(3, StepStatus::kOk));
  plots[1].y() = std::numeric_limits<double>::infinity();
  testing::expect_refused_plot_keeps_the_track(bank, plots, 4, expect_same_mu_and_fusion);
  EXPECT_TRUE(bank.fused(1));  // from the last successful step

  // A track at the radar with no velocity: the range and azimuth are undefined at its
  // prediction, as the one-track filter says, and it stays where it was.
  GaussianState<6> origin = start_of(2);
  origin.mean.setZero();
  bank.initialize(2, origin);
  WimmFilter single(spec);
  single.initialize(origin.mean, origin.covariance);
  bank.step(plots, status);
  EXPECT_EQ(status[2], StepStatus::kUndefinedMeasurement);
  EXPECT_EQ(single.step(plots[2]), StepStatus::kUndefinedMeasurement);
  EXPECT_EQ(bank.estimate(2).mean, Vector<6>::Zero());
}

// The nIMM's gating matrix (no fusion, the extended update: the split cycle), of tracks followed
// for `scans` scans beside their one-track filters, equals the filters' candidate questions after
// predict() to 1e-11 relative (the bank follows the filter to rounding), and asking changes no
// track.
void expect_gating_as_the_one_track_filters(const WimmSpec& spec, int scans, std::mt19937_64& rng,
                                            const std::string& name) {
  constexpr int kTracks = 13;
  WimmTrackBank bank(spec, kTracks);
  auto single =
      testing::one_track_filters(kTracks, [&] { return std::make_unique<WimmFilter>(spec); });
  testing::expect_gating_without_changing_a_track(
      bank, single, name, 1, scans, start_of,
      [&](int t, int k) { return plot_of(spec, t, k, rng); },
      [&](std::size_t t, const std::string& at) { expect_close(bank, t, *single[t], at); }, 1e-11,
      2);
}

TEST(WimmTrackBank, AnNimmScoresCandidatePlotsAsTheOneTrackFilterWithoutChangingATrack) {
  std::mt19937_64 rng(3122026);
  for (int trial = 0; trial < 6; ++trial) {
    WimmSpec spec = random_spec(rng, 3 * trial);  // fusion kNone, the extended update
    ASSERT_EQ(spec.fusion, FusionVariant::kNone);
    spec.update = MeasurementUpdate::kExtended;
    expect_gating_as_the_one_track_filters(spec, 60, rng, "trial " + std::to_string(trial));
    if (HasFailure()) return;
  }
  expect_gating_as_the_one_track_filters(io::read_wimm("models/baseline_nimm_air_surveillance.h5"),
                                         80, rng, "baseline nIMM");
}

// A wIMM that fuses the azimuth or converts the plot has no split cycle: no gating matrix.
TEST(WimmTrackBank, AFusingOrConvertingWimmRefusesTheGatingQuestion) {
  std::mt19937_64 rng(4);
  for (int trial : {1, 2, 3}) {  // seed fusion; correlated fusion; no fusion, converted plots
    const WimmSpec spec = random_spec(rng, trial);
    ASSERT_FALSE(spec.fusion == FusionVariant::kNone &&
                 spec.update == MeasurementUpdate::kExtended);
    WimmTrackBank bank(spec, 2);
    bank.initialize(0, start_of(0));
    const std::vector<Eigen::Vector2d> plots(1, Eigen::Vector2d(3e4, 0.5));
    Eigen::MatrixXd out(1, 1);
    EXPECT_THROW(bank.candidate_log_likelihoods(plots, 9.0, out), std::logic_error) << trial;
  }
}

TEST(WimmTrackBank, RefusesWhatItCannotRun) {
  WimmSpec spec;
  spec.sample_period = 2.0;
  EXPECT_EQ(testing::refused_field<WimmTrackBank>(spec, 0), "capacity");
  spec.transition << 1.0, 0.0, 0.05, 0.95;  // CV absorbing: the Singer mode could be unreachable
  EXPECT_EQ(testing::refused_field<WimmTrackBank>(spec, 4), "transition");
  spec = WimmSpec();
  spec.sample_period = 2.0;
  spec.alpha = 0.0;
  EXPECT_EQ(testing::refused_field<WimmTrackBank>(spec, 4), "alpha");
  spec = WimmSpec();
  spec.sample_period = 2.0;
  WimmTrackBank bank(spec, 3);
  GaussianState<6> bad = start_of(0);
  bad.mean(4) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(testing::refused_field_of([&] { bank.initialize(0, bad); }), "initial_state");
  testing::expect_refused_misuse(bank, start_of(0), Eigen::Vector2d(3e4, 0.5));
  spec.fusion = FusionVariant::kNone;  // the nIMM answers the gating question
  WimmTrackBank nimm(spec, 3);
  testing::expect_refused_misuse(nimm, start_of(0), Eigen::Vector2d(3e4, 0.5));
  testing::expect_refused_gating(nimm);
}

}  // namespace
}  // namespace imm
