// SPDX-License-Identifier: Apache-2.0
// TrackBank::candidate_log_likelihoods: the gating question for many tracks and plots in one call.
// Each (track, plot) entry against the one-track IMM's split cycle (ImmEstimator::predict, then
// candidate_log_likelihood and candidate_distance), with 1, 3 and 6 modes and tracks in whole
// packs and left over; the gate skips exactly the pairs whose distance exceeds it; the call changes
// no track; and what it refuses.

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>

#include "imm/core/invalid_parameter.hpp"
#include "imm/filters/plain_imm.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/math/chi_square.hpp"
#include "imm/tracking/plain_imm_track_bank.hpp"
#include "imm/tracking/track_bank.hpp"
#include "testing/specs.hpp"

namespace imm {
namespace {

// n CV modes with noise levels 10⁻⁶ … 10⁻², a correlated R.
PlainImmSpec spec_with_modes(int n) {
  std::vector<ModeSpec> modes;
  for (int j = 0; j < n; ++j) {
    const double q = std::pow(10.0, -6.0 + 4.0 * j / std::max(n - 1, 1));
    std::string name = "q";  // appended, not "q" + …: GCC 12's -Wrestrict misreads the latter
    name += std::to_string(j);
    modes.push_back(testing::mode_spec(name, MotionKind::kConstantVelocity, q));
  }
  Eigen::Matrix2d R;
  R << 0.25, 0.02, 0.02, 0.3;
  return testing::switching_spec(std::move(modes), 1.0, 0.04, MeasurementKind::kCartesian, R);
}

GaussianState<4> start_for(std::size_t track) {
  GaussianState<4> state;
  const auto t = static_cast<double>(track);
  state.mean << 10.0 + 3.0 * t, 0.1, -5.0 + t, 0.2 - 0.01 * t;
  state.covariance = Eigen::Vector4d(0.25, 0.05, 0.25, 0.05).asDiagonal();
  state.covariance(0, 1) = state.covariance(1, 0) = 0.01;
  return state;
}

// Tracks stepped alike in a bank and as one-track IMMs, so their predictions agree.
struct Tracks {
  TrackBank bank;
  std::vector<ImmEstimator<4, 2>> alone;
  Tracks(const PlainImmSpec& spec, std::size_t n) : bank(spec, n) {
    for (std::size_t t = 0; t < n; ++t) {
      bank.initialize(t, start_for(t));
      alone.push_back(build_plain_imm<4>(spec));
      alone.back().initialize(start_for(t));
    }
  }
  void step(int scans, std::mt19937_64& rng) {
    std::normal_distribution<double> noise(0.0, 0.5);
    std::vector<Eigen::Vector2d> plots(alone.size());
    std::vector<StepStatus> status(alone.size());
    for (int k = 1; k <= scans; ++k) {
      for (std::size_t t = 0; t < alone.size(); ++t) {
        const double turn = t % 3 == 0 && k > 5 ? 0.02 * k * k : 0.0;
        plots[t] = Eigen::Vector2d(10.0 + 3.0 * static_cast<double>(t) + 0.1 * k + turn,
                                   -5.0 + static_cast<double>(t) + 0.2 * k) +
                   Eigen::Vector2d(noise(rng), noise(rng));
        ASSERT_EQ(alone[t].step(plots[t]), StepStatus::kOk);
      }
      bank.step(plots, status);
    }
  }
};

// Candidates around the tracks' predicted plots (after ImmEstimator::predict): near and farther
// from every other track, one far from all, and one unusable.
std::vector<Eigen::Vector2d> candidates(const std::vector<ImmEstimator<4, 2>>& predicted,
                                        std::mt19937_64& rng) {
  std::normal_distribution<double> spread(0.0, 2.0), close(0.0, 0.3);
  std::vector<Eigen::Vector2d> plots;
  for (std::size_t t = 0; t < predicted.size(); t += 2) {
    Vector<2> z_hat = Vector<2>::Zero();
    SquareMatrix<2> S;
    EXPECT_TRUE(predicted[t].predicted_plot(z_hat, S));
    plots.push_back(z_hat + Eigen::Vector2d(close(rng), close(rng)));
    plots.push_back(z_hat + Eigen::Vector2d(spread(rng), spread(rng)));
  }
  plots.emplace_back(1e4, -1e4);
  plots.emplace_back(std::nan(""), 0.0);
  return plots;
}

TEST(TrackBankGating, EveryPairEqualsTheOneTrackSplitCycleAndTheGateSkipsExactlyTheFarOnes) {
  const double gate = chi_square_quantile(0.99, 2);
  for (const int n : {1, 3, 6}) {
    for (const std::size_t count : {std::size_t{1}, std::size_t{19}}) {
      SCOPED_TRACE(::testing::Message() << n << " modes, " << count << " tracks");
      std::mt19937_64 rng(7 + n);
      Tracks tracks(spec_with_modes(n), count);
      tracks.step(12, rng);
      for (ImmEstimator<4, 2>& imm : tracks.alone) imm.predict();
      const std::vector<Eigen::Vector2d> plots = candidates(tracks.alone, rng);
      Eigen::MatrixXd gated(count, plots.size()), all(count, plots.size());
      tracks.bank.candidate_log_likelihoods(plots, gate, gated);
      tracks.bank.candidate_log_likelihoods(plots, std::numeric_limits<double>::infinity(), all);
      int inside = 0, outside = 0;
      for (std::size_t t = 0; t < count; ++t) {
        const ImmEstimator<4, 2>& imm = tracks.alone[t];
        for (std::size_t q = 0; q < plots.size(); ++q) {
          const auto r = static_cast<Eigen::Index>(t), c = static_cast<Eigen::Index>(q);
          const double expected = imm.candidate_log_likelihood(plots[q]);
          const double distance = imm.candidate_distance(plots[q]);
          if (!plots[q].allFinite()) {
            EXPECT_TRUE(std::isnan(gated(r, c)) && std::isnan(all(r, c)));
            continue;
          }
          ASSERT_TRUE(std::isfinite(expected));
          EXPECT_NEAR(all(r, c), expected, 1e-9 * std::max(1.0, std::abs(expected))) << t << q;
          if (distance > gate * (1 + 1e-9)) {
            EXPECT_EQ(gated(r, c), -std::numeric_limits<double>::infinity()) << t << " " << q;
            ++outside;
          } else if (distance < gate * (1 - 1e-9)) {
            EXPECT_EQ(gated(r, c), all(r, c)) << t << " " << q;
            ++inside;
          }
        }
      }
      EXPECT_GT(inside, 0);
      EXPECT_GT(outside, 0);
    }
  }
}

// Asking changes nothing: the next step equals, to the bit, a bank that was never asked.
TEST(TrackBankGating, AskingChangesNoTrack) {
  const PlainImmSpec spec = spec_with_modes(3);
  std::mt19937_64 rng(3), same(3);
  Tracks asked(spec, 11), not_asked(spec, 11);
  asked.step(5, rng);
  not_asked.step(5, same);
  std::vector<Eigen::Vector2d> plots;
  for (int q = 0; q < 6; ++q) plots.emplace_back(10.0 + 4.0 * q, -4.0 + q);
  Eigen::MatrixXd out(11, plots.size());
  asked.bank.candidate_log_likelihoods(plots, 9.21, out);
  std::vector<Eigen::Vector2d> next(11, Eigen::Vector2d(20.0, 1.0));
  std::vector<StepStatus> a(11), b(11);
  asked.bank.step(next, a);
  not_asked.bank.step(next, b);
  for (std::size_t t = 0; t < 11; ++t) {
    const auto x = asked.bank.estimate(t), y = not_asked.bank.estimate(t);
    EXPECT_EQ(std::memcmp(x.mean.data(), y.mean.data(), sizeof(double) * 4), 0);
    EXPECT_EQ(std::memcmp(x.covariance.data(), y.covariance.data(), sizeof(double) * 16), 0);
    EXPECT_EQ(asked.bank.log_mode_probabilities(t), not_asked.bank.log_mode_probabilities(t));
  }
}

TEST(TrackBankGating, RefusesAWrongShapeABadGateAndAnUninitializedTrack) {
  TrackBank bank(spec_with_modes(3), 4);
  for (std::size_t t = 0; t < 3; ++t) bank.initialize(t, start_for(t));
  const std::vector<Eigen::Vector2d> plots(2, Eigen::Vector2d(1.0, 2.0));
  Eigen::MatrixXd out(3, 2), wrong(3, 3), too_many(5, 2), four(4, 2);
  EXPECT_THROW(bank.candidate_log_likelihoods(plots, 9.0, wrong), std::invalid_argument);
  EXPECT_THROW(bank.candidate_log_likelihoods(plots, 9.0, too_many), std::invalid_argument);
  for (const double gate : {0.0, -1.0, std::nan("")}) {
    try {
      bank.candidate_log_likelihoods(plots, gate, out);
      ADD_FAILURE() << gate;
    } catch (const InvalidParameter& error) {
      EXPECT_EQ(error.field(), "gate");
    }
  }
  EXPECT_THROW(bank.candidate_log_likelihoods(plots, 9.0, four), std::logic_error);
  bank.candidate_log_likelihoods(plots, 9.0, out);
  EXPECT_TRUE((out.array() == out.array()).all());  // no NaN: a number or −∞
}

// A start of the general bank's state layout: [x, vx, y, vy, ω] (CV + CT) or
// [x, vx, ax, y, vy, ay, ω] (CV + CA + CT).
template <int NX>
GaussianState<NX> turn_imm_start(double x, double y) {
  GaussianState<NX> s;
  s.mean.setZero();
  s.covariance.setZero();
  const int per_axis = NX == 7 ? 3 : 2;
  const double values[2][3] = {{x, -150.0, 0.0}, {y, 60.0, 0.0}};
  const double variances[3] = {400.0, 100.0, 1.0};
  for (int axis = 0; axis < 2; ++axis) {
    for (int d = 0; d < per_axis; ++d) {
      s.mean(axis * per_axis + d) = values[axis][d];
      s.covariance(axis * per_axis + d, axis * per_axis + d) = variances[d];
    }
  }
  s.covariance(NX - 1, NX - 1) = 1e-4;
  return s;
}

// The general bank for one spec of mixing dimension NX: each entry is its track's own split
// cycle (the bank's tracks are one-track IMMs), the gate cuts by candidate_distance, and asking
// leaves the next step's numbers exactly as they would be.
template <int NX>
void check_general_bank(const PlainImmSpec& spec) {
  PlainImmTrackBank<NX> asked(spec, 3), quiet(spec, 3);
  std::vector<ImmEstimator<NX, 2>> alone;
  for (std::size_t t = 0; t < 3; ++t) {
    const GaussianState<NX> s =
        turn_imm_start<NX>(20000.0 + 500.0 * static_cast<double>(t), 15000.0);
    asked.initialize(t, s);
    quiet.initialize(t, s);
    alone.push_back(build_plain_imm<NX>(spec));
    alone.back().initialize(s);
  }
  for (ImmEstimator<NX, 2>& imm : alone) ASSERT_EQ(imm.predict(), StepStatus::kOk);
  // Track 0's predicted plot, one 2σ away, one far from every track, one unusable.
  Vector<2> z_hat;
  SquareMatrix<2> S;
  ASSERT_TRUE(alone[0].predicted_plot(z_hat, S));
  const Eigen::Vector2d sigma = S.diagonal().cwiseSqrt();
  const std::vector<Eigen::Vector2d> plots = {z_hat, z_hat + 2.0 * sigma, z_hat + 1e3 * sigma,
                                              Eigen::Vector2d(std::nan(""), 1.0)};
  Eigen::MatrixXd out(3, 4);
  const double gate = chi_square_quantile(0.99, 2);
  asked.candidate_log_likelihoods(plots, gate, out);
  for (std::size_t t = 0; t < 3; ++t) {
    const auto r = static_cast<Eigen::Index>(t);
    for (std::size_t q = 0; q < 3; ++q) {
      const auto c = static_cast<Eigen::Index>(q);
      if (alone[t].candidate_distance(plots[q]) > gate) {
        EXPECT_EQ(out(r, c), -std::numeric_limits<double>::infinity()) << t << " " << q;
      } else {
        EXPECT_EQ(out(r, c), alone[t].candidate_log_likelihood(plots[q])) << t << " " << q;
      }
    }
    EXPECT_TRUE(std::isnan(out(r, 3)));
  }
  EXPECT_TRUE(std::isfinite(out(0, 0)));  // the plot where track 0 goes
  EXPECT_EQ(out(0, 2), -std::numeric_limits<double>::infinity());
  const std::vector<Eigen::Vector2d> next(3, plots[0]);
  std::vector<StepStatus> a(3), b(3);
  asked.step(next, a);
  quiet.step(next, b);
  for (std::size_t t = 0; t < 3; ++t) {
    EXPECT_EQ(a[t], b[t]);
    const auto x = asked.estimate(t), y = quiet.estimate(t);
    EXPECT_EQ(std::memcmp(x.mean.data(), y.mean.data(), sizeof(double) * NX), 0);
    EXPECT_EQ(std::memcmp(x.covariance.data(), y.covariance.data(), sizeof(double) * NX * NX), 0);
  }
}

// The general bank (CA and turn modes, polar plots) answers for every shipped classical IMM and for
// a scheduled one.
TEST(TrackBankGating, TheGeneralBankAnswersForEveryPlainImm) {
  int answered = 0;
  for (const char* name :
       {"models/classical_imm_agile_air.h5", "models/classical_imm_ground_vehicle.h5",
        "models/classical_imm_air_surveillance.h5"}) {
    SCOPED_TRACE(name);
    const PlainImmSpec spec = io::read_plain_imm(std::filesystem::path(name));
    if (spec.mixing_dimension() == 5) {
      check_general_bank<5>(spec);
      ++answered;
    } else if (spec.mixing_dimension() == 7) {
      check_general_bank<7>(spec);
      ++answered;
    }
  }
  EXPECT_EQ(answered, 3);
  // A scheduled IMM scores by trial updates, gates on its prediction without the plot, and answers
  // the same: every entry its one-track filter's.
  const PlainImmSpec scheduled =
      io::read_plain_imm(std::filesystem::path("models/scheduled_ct_imm_air_surveillance.h5"));
  ASSERT_EQ(scheduled.mixing_dimension(), 5);
  check_general_bank<5>(scheduled);
}

}  // namespace
}  // namespace imm
