// SPDX-License-Identifier: Apache-2.0
#include "imm/tracking/track_bank.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "imm/core/aligned_allocator.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/estimation/imm_estimator.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "testing/axis_lane_bank_checks.hpp"
#include "testing/matrix_checks.hpp"
#include "testing/specs.hpp"
#include "testing/textbook_imm.hpp"

namespace imm {
namespace {

// cv3 with a correlated R and a continuous-noise mode, so every term of the kernel is exercised.
PlainImmSpec bank_spec() {
  PlainImmSpec spec = testing::cv3_spec();
  spec.measurement.covariance << 0.25, 0.02, 0.02, 0.3;
  spec.modes[1].noise_form = NoiseForm::kContinuous;
  return spec;
}

GaussianState<4> start_for(std::size_t track) {
  GaussianState<4> state;
  state.mean << 10.0 + static_cast<double>(track), 0.1, -5.0,
      0.2 - 0.01 * static_cast<double>(track);
  state.covariance = Eigen::Vector4d(0.25, 0.05, 0.25, 0.05).asDiagonal();
  state.covariance(0, 1) = state.covariance(1, 0) = 0.01;
  return state;
}

bool same_bits(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())) == 0;
}

// The plot of track t at scan k: a manoeuvring track with noise from its own seeded stream, a
// missing (NaN) plot now and then, and a restart of track 5 half-way.
struct Scenario {
  std::vector<std::mt19937_64> streams;
  explicit Scenario(std::size_t tracks) {
    for (std::size_t t = 0; t < tracks; ++t) streams.emplace_back(1000 + t);
  }
  Eigen::Vector2d plot(std::size_t t, int k) {
    std::normal_distribution<double> noise(0.0, 0.5);
    const double ax = (k >= 30 + static_cast<int>(t % 7) && k < 50) ? 0.02 : 0.0;
    Eigen::Vector2d z(
        10.0 + static_cast<double>(t) + 0.1 * k + 0.5 * ax * k * k + noise(streams[t]),
        -5.0 + 0.2 * k + noise(streams[t]));
    if ((k + static_cast<int>(t)) % 41 == 0) z(0) = std::nan("");
    return z;
  }
};

// The contract: a bank of N tracks equals N banks of one track to the bit, whatever a track's
// position in its tile (24 whole tiles and a partial one here).
TEST(TrackBank, ManyTracksEqualOneTrackBanksToTheBit) {
  const std::size_t tracks = 24 * TrackBank::kBlock + 5;
  const PlainImmSpec spec = bank_spec();
  TrackBank bank(spec, tracks);
  std::vector<TrackBank> singles;
  for (std::size_t t = 0; t < tracks; ++t) {
    bank.initialize(t, start_for(t));
    singles.emplace_back(spec, 1);
    singles.back().initialize(0, start_for(t));
  }
  Scenario scenario(tracks);
  std::vector<Eigen::Vector2d> plots(tracks);
  std::vector<StepStatus> status(tracks);
  int invalid = 0;
  for (int k = 1; k <= 120; ++k) {
    if (k == 60) {
      bank.initialize(5, start_for(9));
      singles[5].initialize(0, start_for(9));
    }
    for (std::size_t t = 0; t < tracks; ++t) plots[t] = scenario.plot(t, k);
    bank.step(plots, status);
    for (std::size_t t = 0; t < tracks; ++t) {
      StepStatus single_status{};
      singles[t].step({&plots[t], 1}, {&single_status, 1});
      ASSERT_EQ(status[t], single_status) << "track " << t << " scan " << k;
      invalid += status[t] == StepStatus::kInvalidMeasurement ? 1 : 0;
      const auto a = bank.estimate(t), b = singles[t].estimate(0);
      ASSERT_TRUE(same_bits(a.mean, b.mean)) << "track " << t << " scan " << k;
      ASSERT_TRUE(same_bits(a.covariance, b.covariance)) << "track " << t << " scan " << k;
      ASSERT_TRUE(same_bits(bank.log_mode_probabilities(t), singles[t].log_mode_probabilities(0)));
      for (int j = 0; j < bank.mode_count(); ++j) {
        ASSERT_TRUE(same_bits(bank.mode_estimate(t, j).covariance,
                              singles[t].mode_estimate(0, j).covariance));
      }
    }
  }
  EXPECT_GT(invalid, 100);  // the NaN plots were there and were refused
}

// Packs of 8 (AVX-512), 4 (AVX2) and 2 give the same bits: 21 tracks are whole packs and a
// remainder of each kind (a padded pack, a track alone).
TEST(TrackBank, EveryInstructionSetGivesTheSameBits) {
  const PlainImmSpec spec = bank_spec();
  Scenario scenario(21);
  testing::expect_instruction_sets_agree(
      21, 80, [&](std::size_t n) { return TrackBank(spec, n); },
      [](int t) { return start_for(static_cast<std::size_t>(t)); },
      [&](int t, int k) { return scenario.plot(static_cast<std::size_t>(t), k); },
      [](const TrackBank& a, std::size_t t, const TrackBank& b, std::size_t u) {
        testing::expect_same_bits(a.log_mode_probabilities(t), b.log_mode_probabilities(u));
        for (int j = 0; j < a.mode_count(); ++j) {
          testing::expect_same_bits(a.mode_estimate(t, j).covariance,
                                    b.mode_estimate(u, j).covariance);
        }
      });
}

// n CV modes with noise levels 10⁻⁶ … 10⁻², the one of bank_spec() for n = 3.
PlainImmSpec spec_with_modes(int n) {
  if (n == 3) return bank_spec();
  std::vector<ModeSpec> modes;
  for (int j = 0; j < n; ++j) {
    const double q = std::pow(10.0, -6.0 + 4.0 * j / std::max(n - 1, 1));
    std::string name = "q";
    name += std::to_string(j);
    modes.push_back(testing::mode_spec(name, MotionKind::kConstantVelocity, q));
  }
  Eigen::Matrix2d R;
  R << 0.25, 0.02, 0.02, 0.3;
  return testing::switching_spec(std::move(modes), 1.0, 0.04, MeasurementKind::kCartesian, R);
}

// Against the deliberately plain textbook IMM (dynamic sizes, linear probabilities, standard
// covariance update; to 1e-9) and the runtime's generic ImmEstimator (to 1e-12 relative, the
// one-track filter's rounding), on a manoeuvring track: with 1, 3
// (unrolled) and 6 modes (the general loop), for a track alone (the step's double instance) and in
// a pack of lanes (its LanePack instance).
TEST(TrackBank, MatchesTheTextbookImmAndImmEstimator) {
  for (const int n : {1, 3, 6}) {
    for (const std::size_t tracks : {std::size_t{1}, std::size_t{kLanePackWidth + 1}}) {
      SCOPED_TRACE(::testing::Message() << n << " modes, " << tracks << " tracks");
      const PlainImmSpec spec = spec_with_modes(n);
      TrackBank bank(spec, tracks);
      auto reference_imm = build_plain_imm<4>(spec);
      const GaussianState<4> initial = start_for(0);
      for (std::size_t t = 0; t < tracks; ++t) bank.initialize(t, initial);
      reference_imm.initialize(initial);
      Eigen::MatrixXd H = Eigen::MatrixXd::Zero(2, 4);
      H(0, 0) = H(1, 2) = 1.0;
      std::vector<testing::TextbookMode> modes;
      for (const ModeSpec& mode : spec.modes) {
        const auto cv = constant_velocity<2>(1.0, mode.process_noise, mode.noise_form);
        modes.push_back({Eigen::MatrixXd::Identity(4, 4), cv.transition, cv.process_noise, H,
                         spec.measurement.covariance, initial.mean, initial.covariance});
      }
      testing::TextbookImm textbook(modes, spec.transition, spec.initial_probabilities);
      std::mt19937_64 rng(99);
      std::normal_distribution<double> noise(0.0, 0.5);
      std::vector<Eigen::Vector2d> plots(tracks);
      std::vector<StepStatus> status(tracks);
      for (int k = 1; k <= 160; ++k) {
        const double ax = (k >= 40 && k < 60) ? 0.01 : 0.0;
        const Vector<2> z(10.0 + 0.1 * k + 0.5 * ax * k * k + noise(rng),
                          -5.0 + 0.2 * k + noise(rng));
        std::fill(plots.begin(), plots.end(), z);
        bank.step(plots, status);
        textbook.step(z);
        ASSERT_EQ(reference_imm.step(z), StepStatus::kOk);
        for (std::size_t t = 0; t < tracks; ++t) {
          ASSERT_EQ(status[t], StepStatus::kOk);
          const auto estimate = bank.estimate(t);
          ASSERT_TRUE(testing::matrices_near(estimate.mean, textbook.mean(), 1e-9)) << k;
          ASSERT_TRUE(testing::matrices_near(estimate.covariance, textbook.covariance(), 1e-9));
          ASSERT_TRUE(
              testing::matrices_near(bank.mode_probabilities(t), textbook.probabilities(), 1e-9));
          ASSERT_TRUE(testing::matrices_near(estimate.mean, reference_imm.estimate().mean, 1e-12));
          ASSERT_TRUE(testing::matrices_near(estimate.covariance,
                                             reference_imm.estimate().covariance, 1e-12));
          ASSERT_TRUE(testing::matrices_near(bank.mode_probabilities(t),
                                             reference_imm.mode_probabilities(), 1e-12));
          ASSERT_EQ(estimate.covariance, estimate.covariance.transpose());  // a triangle
        }
      }
    }
  }
}

// The step that states the NIS: each track's NIS is its ImmEstimator's νᵀ S⁻¹ ν after the same step
// (ImmEstimator::innovation; 1e-9 relative, the kernel's rounding), NaN where the step failed, and
// stating it changes no bit of any track (a bank stepped without it stays equal), with 1, 3 and 6
// modes, for a track alone, a block and a partial one.
TEST(TrackBank, TheNisItStatesIsImmEstimatorsAndChangesNoTrack) {
  for (const int n : {1, 3, 6}) {
    for (const std::size_t tracks : {std::size_t{1}, std::size_t{9}, std::size_t{13}}) {
      SCOPED_TRACE(::testing::Message() << n << " modes, " << tracks << " tracks");
      const PlainImmSpec spec = spec_with_modes(n);
      TrackBank bank(spec, tracks), silent(spec, tracks);
      std::vector<ImmEstimator<4, 2>> references;
      for (std::size_t t = 0; t < tracks; ++t) {
        bank.initialize(t, start_for(t));
        silent.initialize(t, start_for(t));
        references.push_back(build_plain_imm<4>(spec));
        references.back().initialize(start_for(t));
      }
      Scenario scenario(tracks);
      std::vector<Eigen::Vector2d> plots(tracks);
      std::vector<StepStatus> status(tracks), silent_status(tracks);
      std::vector<double> nis(tracks);
      int failed = 0;
      for (int k = 1; k <= 100; ++k) {
        for (std::size_t t = 0; t < tracks; ++t) plots[t] = scenario.plot(t, k);
        bank.step(plots, status, nis);
        silent.step(plots, silent_status);
        for (std::size_t t = 0; t < tracks; ++t) {
          ASSERT_EQ(status[t], silent_status[t]);
          ASSERT_EQ(status[t], references[t].step(plots[t])) << k;
          ASSERT_TRUE(same_bits(bank.estimate(t).covariance, silent.estimate(t).covariance));
          ASSERT_TRUE(same_bits(bank.log_mode_probabilities(t), silent.log_mode_probabilities(t)));
          if (status[t] != StepStatus::kOk) {
            EXPECT_TRUE(std::isnan(nis[t])) << k;
            ++failed;
            continue;
          }
          Vector<2> nu;
          SquareMatrix<2> S;
          ASSERT_TRUE(references[t].innovation(nu, S));
          const double expected = nu.dot(S.ldlt().solve(nu));
          ASSERT_NEAR(nis[t], expected, 1e-9 * expected) << k << " track " << t;
        }
      }
      EXPECT_GT(failed, 0);  // the NaN plots
    }
  }
}

// A plot 10⁴ σ away: every likelihood underflows in linear space; the log-space probabilities
// still agree with ImmEstimator's, and nothing becomes NaN.
TEST(TrackBank, ModeProbabilitiesSurviveLikelihoodUnderflow) {
  const PlainImmSpec spec = testing::cv3_spec();
  TrackBank bank(spec, 1);
  auto reference = build_plain_imm<4>(spec);
  bank.initialize(0, start_for(0));
  reference.initialize(start_for(0));
  const Eigen::Vector2d z(5000.0, 5000.0);
  StepStatus status{};
  bank.step({&z, 1}, {&status, 1});
  ASSERT_EQ(status, StepStatus::kOk);
  ASSERT_EQ(reference.step(z), StepStatus::kOk);
  EXPECT_TRUE(testing::matrices_near(bank.log_mode_probabilities(0),
                                     reference.log_mode_probabilities(), 1e-9));
  EXPECT_TRUE(bank.estimate(0).all_finite());
  EXPECT_NEAR(bank.mode_probabilities(0).sum(), 1.0, 1e-12);
}

// A step of fewer tracks than a pack holds runs them in a pack whose other lanes are tracks not
// stepped (and lanes past the capacity): those keep their state to the bit, and the stepped ones
// equal banks of one track.
TEST(TrackBank, TracksPastTheSteppedOnesAreNotTouched) {
  for (std::size_t stepped = 2; stepped <= 7; ++stepped) {
    TrackBank bank(testing::cv3_spec(), 9);
    std::vector<TrackBank> singles;
    for (std::size_t t = 0; t < 9; ++t) {
      bank.initialize(t, start_for(t));
      singles.emplace_back(testing::cv3_spec(), 1);
      singles.back().initialize(0, start_for(t));
    }
    const TrackBank before = bank;
    Scenario scenario(stepped);
    std::vector<Eigen::Vector2d> plots(stepped);
    std::vector<StepStatus> status(stepped);
    for (int k = 1; k <= 20; ++k) {
      for (std::size_t t = 0; t < stepped; ++t) plots[t] = scenario.plot(t, k);
      bank.step(plots, status);
      for (std::size_t t = 0; t < stepped; ++t) {
        StepStatus single_status{};
        singles[t].step({&plots[t], 1}, {&single_status, 1});
        ASSERT_EQ(status[t], single_status) << stepped << " stepped, track " << t;
        ASSERT_TRUE(same_bits(bank.estimate(t).mean, singles[t].estimate(0).mean));
        ASSERT_TRUE(
            same_bits(bank.log_mode_probabilities(t), singles[t].log_mode_probabilities(0)));
      }
    }
    for (std::size_t t = stepped; t < 9; ++t) {
      EXPECT_TRUE(same_bits(bank.estimate(t).mean, before.estimate(t).mean)) << t;
      EXPECT_TRUE(same_bits(bank.estimate(t).covariance, before.estimate(t).covariance)) << t;
      EXPECT_TRUE(same_bits(bank.log_mode_probabilities(t), before.log_mode_probabilities(t))) << t;
    }
  }
}

// A refused plot leaves its track exactly as it was and does not disturb its neighbours.
TEST(TrackBank, RefusedPlotLeavesTheTrackUnchanged) {
  TrackBank bank(testing::cv3_spec(), 2);
  bank.initialize(0, start_for(0));
  bank.initialize(1, start_for(1));
  const auto before = bank.estimate(0);
  const auto mu_before = bank.log_mode_probabilities(0);
  for (const Eigen::Vector2d& bad : {Eigen::Vector2d(std::nan(""), 0.0),
                                     Eigen::Vector2d(0.0, INFINITY), Eigen::Vector2d(2e9, 0.0)}) {
    std::array<Eigen::Vector2d, 2> plots = {bad, Eigen::Vector2d(11.1, -4.8)};
    std::array<StepStatus, 2> status{};
    bank.step(plots, status);
    EXPECT_EQ(status[0], StepStatus::kInvalidMeasurement);
    EXPECT_EQ(status[1], StepStatus::kOk);
    EXPECT_TRUE(same_bits(bank.estimate(0).mean, before.mean));
    EXPECT_TRUE(same_bits(bank.estimate(0).covariance, before.covariance));
    EXPECT_TRUE(same_bits(bank.log_mode_probabilities(0), mu_before));
  }
}

// The banks' storage starts on a cache line whatever its size, and behaves as a vector.
TEST(AlignedAllocator, EveryBlockStartsOnTheBoundary) {
  for (std::size_t n = 1; n < 300; n += 7) {
    std::vector<double, AlignedAllocator<double>> v(n, 1.5);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(v.data()) % 64, 0U) << n;
    v.resize(3 * n + 1, 2.5);  // reallocates
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(v.data()) % 64, 0U) << n;
    EXPECT_EQ(v[n - 1], 1.5);
    EXPECT_EQ(v[3 * n], 2.5);
  }
  std::vector<char, AlignedAllocator<char, 256>> bytes(3);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(bytes.data()) % 256, 0U);
}

TEST(TrackBank, RefusesWhatItCannotRun) {
  PlainImmSpec polar = testing::cv3_spec();
  polar.measurement.kind = MeasurementKind::kPolar;
  polar.measurement.covariance << 100.0, 0.0, 0.0, 1e-4;
  try {
    TrackBank bank(polar, 4);
    FAIL() << "a polar measurement was accepted";
  } catch (const InvalidParameter& e) {
    EXPECT_EQ(e.field(), "measurement.kind");
  }
  PlainImmSpec ca = testing::cv3_spec();
  ca.modes[1].motion = MotionKind::kConstantAcceleration;
  try {
    TrackBank bank(ca, 4);
    FAIL() << "a CA mode was accepted";
  } catch (const InvalidParameter& e) {
    EXPECT_EQ(e.field(), "modes[1].motion");
  }
  EXPECT_THROW(TrackBank(testing::cv3_spec(), 0), InvalidParameter);

  TrackBank bank(testing::cv3_spec(), 2);
  bank.initialize(0, start_for(0));
  std::array<Eigen::Vector2d, 2> two = {Eigen::Vector2d(1, 1), Eigen::Vector2d(1, 1)};
  std::array<StepStatus, 2> status{};
  EXPECT_THROW(bank.step(two, status), std::logic_error);  // track 1 never initialized
  std::array<Eigen::Vector2d, 3> three{};
  std::array<StepStatus, 3> three_status{};
  EXPECT_THROW(bank.step(three, three_status), std::invalid_argument);
  EXPECT_THROW(bank.initialize(2, start_for(0)), std::out_of_range);
  EXPECT_THROW((void)bank.estimate(5), std::out_of_range);
}

}  // namespace
}  // namespace imm
