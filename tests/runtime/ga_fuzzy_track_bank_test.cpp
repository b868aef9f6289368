// SPDX-License-Identifier: Apache-2.0
// The GA-fuzzy IMM bank against the one-track filter (make_ga_fuzzy_imm_filter): statuses,
// estimates and mode probabilities to rounding over random specs, tracks independent of their
// neighbours to the bit, refused plots leaving a track exactly as it was, and what it refuses.
#include "imm/tracking/ga_fuzzy_track_bank.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/filters/ga_fuzzy_imm.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "testing/axis_lane_bank_checks.hpp"
#include "testing/ga_fuzzy_specs.hpp"

namespace imm {
namespace {

// A random spec (testing/ga_fuzzy_specs.hpp) at a random sample period and plot σ.
GaFuzzyImmSpec random_spec(datasets::Rng& rng, int levels, FuzzyAntecedents antecedents) {
  GaFuzzyImmSpec spec = testing::random_ga_fuzzy_spec(rng, levels, antecedents);
  spec.settings.sample_period = rng.uniform(0.5, 2.5);
  spec.settings.measurement_sigma = rng.uniform(0.2, 1.2);
  return spec;
}

GaussianState<4> start_of(int track) {
  GaussianState<4> s;
  s.mean << 10.0 + track, 0.3, -4.0 + 0.5 * track, -0.2;
  s.covariance = Eigen::Vector4d(2.0, 0.5, 2.0, 0.5).asDiagonal();
  s.covariance(0, 1) = s.covariance(1, 0) = 0.3;
  s.covariance(2, 3) = s.covariance(3, 2) = -0.2;
  return s;
}

// Plots of track t at scan k: a weaving target with noise, a NaN or an out-of-range plot now and
// then.
Eigen::Vector2d plot_of(int track, int k, std::mt19937_64& rng) {
  std::normal_distribution<double> noise(0.0, 0.5);
  const double time = k;
  Eigen::Vector2d z(10.0 + track + 0.3 * time + 3.0 * std::sin(0.05 * time * (1 + track % 3)),
                    -4.0 + 0.5 * track - 0.2 * time + 2.0 * std::cos(0.07 * time));
  z += Eigen::Vector2d(noise(rng), noise(rng));
  if ((k + track) % 29 == 3) z.y() = std::numeric_limits<double>::quiet_NaN();
  if ((k * 7 + track) % 53 == 11) z.x() = 1e300;
  return z;
}

TEST(GaFuzzyTrackBank, EqualsTheOneTrackFilterToRounding) {
  datasets::Rng specs(26112026);
  std::mt19937_64 rng(26112026);
  int refused = 0;
  for (int trial = 0; trial < 8; ++trial) {
    const auto antecedents =
        trial % 2 == 0 ? FuzzyAntecedents::kResidual : FuzzyAntecedents::kNormalizedInnovation;
    const GaFuzzyImmSpec spec = random_spec(specs, 1 + trial % 4, antecedents);
    constexpr int kTracks = 13;  // three whole blocks of four tracks and one track more
    GaFuzzyTrackBank bank(spec, kTracks);
    auto single =
        testing::one_track_filters(kTracks, [&] { return make_ga_fuzzy_imm_filter(spec); });
    refused += testing::follow_one_track_filters(
        bank, single, "trial " + std::to_string(trial), 0, 119, start_of,
        [&](int t, int k) { return plot_of(t, k, rng); },
        [&](std::size_t t, const std::string& at) {
          testing::expect_two_axis_close(bank, t, *single[t], at);
        });
    if (HasFailure()) return;
  }
  EXPECT_GT(refused, 100);  // the NaN and out-of-range plots were refused, by both
}

TEST(GaFuzzyTrackBank, ATracksResultDoesNotDependOnItsNeighboursToTheBit) {
  datasets::Rng specs(7);
  std::mt19937_64 rng(7);
  const GaFuzzyImmSpec spec = random_spec(specs, 3, FuzzyAntecedents::kNormalizedInnovation);
  testing::expect_tracks_independent_of_their_neighbours(
      11, 80, [&](std::size_t n) { return GaFuzzyTrackBank(spec, n); }, start_of,
      [&](int t, int k) { return plot_of(t, k, rng); }, testing::expect_same_mu<GaFuzzyTrackBank>);
}

// Blocks of 16 lanes (where the AVX-512 clone runs) and of 8 give the same bits: both run here
// whatever the CPU; 13 tracks are one whole block of 16 lanes and a partial one.
TEST(GaFuzzyTrackBank, TheWideAndNarrowBlocksGiveTheSameBits) {
  datasets::Rng specs(19);
  std::mt19937_64 rng(19);
  const GaFuzzyImmSpec spec = random_spec(specs, 3, FuzzyAntecedents::kResidual);
  testing::expect_wide_blocks_as_narrow_ones(
      13, 80, [&](std::size_t n, bool wide) { return GaFuzzyTrackBank(spec, n, wide); }, start_of,
      [&](int t, int k) { return plot_of(t, k, rng); }, testing::expect_same_mu<GaFuzzyTrackBank>);
}

// Packs of 8 (AVX-512), 4 (AVX2) and 2 give the same bits, wide blocks and narrow ones.
TEST(GaFuzzyTrackBank, EveryInstructionSetGivesTheSameBits) {
  datasets::Rng specs(23);
  std::mt19937_64 rng(23);
  const GaFuzzyImmSpec spec = random_spec(specs, 3, FuzzyAntecedents::kNormalizedInnovation);
  for (const bool wide : {true, false}) {
    testing::expect_instruction_sets_agree(
        13, 60, [&](std::size_t n) { return GaFuzzyTrackBank(spec, n, wide); }, start_of,
        [&](int t, int k) { return plot_of(t, k, rng); },
        testing::expect_same_mu<GaFuzzyTrackBank>);
  }
}

TEST(GaFuzzyTrackBank, ARefusedPlotLeavesTheTrackExactlyAsItWasAndLaterTracksUntouched) {
  datasets::Rng specs(11);
  const GaFuzzyImmSpec spec = random_spec(specs, 2, FuzzyAntecedents::kResidual);
  GaFuzzyTrackBank bank(spec, 6);
  for (std::size_t t = 0; t < 6; ++t) bank.initialize(t, start_of(static_cast<int>(t)));
  std::vector<Eigen::Vector2d> plots{{10.2, -4.1}, {11.0, -3.4}, {12.1, -3.1}};
  std::vector<StepStatus> status(3);
  bank.step(plots, status);
  plots[1].y() = std::numeric_limits<double>::infinity();
  testing::expect_refused_plot_keeps_the_track(bank, plots, 4,
                                               testing::expect_same_mu<GaFuzzyTrackBank>);
}

// The gating matrix of tracks followed for `scans` scans beside their one-track filters equals
// the filters' candidate questions after predict() (trial updates: the modes' noise reads the
// plot) to 1e-12 relative, and asking changes no track: the next step still follows the filters'
// update.
void expect_gating_as_the_one_track_filters(const GaFuzzyImmSpec& spec, int scans,
                                            std::mt19937_64& rng, const std::string& name) {
  constexpr int kTracks = 13;
  GaFuzzyTrackBank bank(spec, kTracks);
  auto single = testing::one_track_filters(kTracks, [&] { return make_ga_fuzzy_imm_filter(spec); });
  testing::expect_gating_without_changing_a_track(
      bank, single, name, 0, scans - 1, start_of, [&](int t, int k) { return plot_of(t, k, rng); },
      [&](std::size_t t, const std::string& at) {
        testing::expect_two_axis_close(bank, t, *single[t], at);
      },
      1e-12, 2);
}

TEST(GaFuzzyTrackBank, ScoresCandidatePlotsAsTheOneTrackFilterWithoutChangingATrack) {
  datasets::Rng specs(3122026);
  std::mt19937_64 rng(3122026);
  for (int trial = 0; trial < 10; ++trial) {  // 1 to 5 levels: every unrolled count and the rest
    const auto antecedents =
        trial % 2 == 0 ? FuzzyAntecedents::kResidual : FuzzyAntecedents::kNormalizedInnovation;
    expect_gating_as_the_one_track_filters(random_spec(specs, 1 + trial % 5, antecedents), 40, rng,
                                           "trial " + std::to_string(trial));
    if (HasFailure()) return;
  }
  for (const char* name : {"ga_fuzzy_imm.h5", "ga_fuzzy_imm_agile_air.h5"}) {
    expect_gating_as_the_one_track_filters(io::read_ga_fuzzy_imm(std::string("models/") + name), 60,
                                           rng, name);
  }
}

// A step that states its NIS writes one NIS per stepped track and nothing past them, whatever the
// count of stepped tracks in the last block, in wide blocks and in narrow ones (whose second half
// may hold no track at all).
TEST(GaFuzzyTrackBank, StatingTheNisWritesEachSteppedTrackAndNothingPastThem) {
  datasets::Rng specs(5);
  const GaFuzzyImmSpec spec = random_spec(specs, 3, FuzzyAntecedents::kResidual);
  constexpr std::size_t kCapacity = 19;
  constexpr double kUntouched = -12345.0;
  for (const bool wide : {true, false}) {
    GaFuzzyTrackBank bank(spec, kCapacity, wide);
    for (std::size_t t = 0; t < kCapacity; ++t) bank.initialize(t, start_of(static_cast<int>(t)));
    for (std::size_t n = 1; n <= kCapacity; ++n) {
      std::vector<Eigen::Vector2d> plots;
      for (std::size_t t = 0; t < n; ++t) {
        plots.push_back(start_of(static_cast<int>(t)).mean({0, 2}));
      }
      std::vector<StepStatus> status(n);
      std::vector<double> nis(n + 16, kUntouched);
      bank.step(plots, status, std::span<double>(nis.data(), n));
      for (std::size_t t = 0; t < n; ++t) {
        ASSERT_EQ(status[t], StepStatus::kOk) << n << " tracks, track " << t;
        EXPECT_TRUE(std::isfinite(nis[t]) && nis[t] >= 0.0) << n << " tracks, track " << t;
      }
      for (std::size_t i = n; i < nis.size(); ++i) {
        ASSERT_EQ(nis[i], kUntouched) << (wide ? "wide" : "narrow") << ", " << n << " tracks";
      }
    }
  }
}

TEST(GaFuzzyTrackBank, RefusesWhatItCannotRun) {
  datasets::Rng specs(3);
  GaFuzzyImmSpec spec = random_spec(specs, 2, FuzzyAntecedents::kResidual);
  EXPECT_EQ(testing::refused_field<GaFuzzyTrackBank>(spec, 0), "capacity");
  spec.settings.transition_stay = 1.0;  // zero transitions: a mode could become unreachable
  EXPECT_EQ(testing::refused_field<GaFuzzyTrackBank>(spec, 4), "settings.transition_stay");
  spec.levels.clear();
  EXPECT_EQ(testing::refused_field<GaFuzzyTrackBank>(spec, 4), "levels");
  spec = random_spec(specs, 1, FuzzyAntecedents::kResidual);
  spec.settings.transition_stay = 1.0;  // one level: [[1]] is fine
  GaFuzzyTrackBank bank(spec, 3);
  testing::expect_refused_misuse(bank, start_of(0), Eigen::Vector2d(1.0, 2.0));
  testing::expect_refused_gating(bank);
}

}  // namespace
}  // namespace imm
