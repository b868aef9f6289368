// SPDX-License-Identifier: Apache-2.0
#pragma once
// Properties of the multi-track banks, checked the same way: a track's result does not depend on
// its neighbours, every instruction set's kernel gives the same, and, in the banks of two-axis-lane
// tracks, blocks of 16 lanes give what blocks of 8 give — to the bit; what every bank refuses,
// naming the field or by the exception's type.

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/estimation/gaussian_state.hpp"
#include "imm/estimation/step_status.hpp"
#include "imm/filters/axis_filter.hpp"
#include "imm/math/chi_square.hpp"
#include "imm/math/lane_isa.hpp"
#include "imm/math/linear_algebra.hpp"
#include "testing/refused_field.hpp"

namespace imm::testing {

// Equal bit for bit, entry by entry (−0 ≠ +0; a NaN equals the same NaN).
template <class A, class B>
void expect_same_bits(const Eigen::DenseBase<A>& a, const Eigen::DenseBase<B>& b) {
  ASSERT_EQ(a.rows(), b.rows());
  ASSERT_EQ(a.cols(), b.cols());
  for (Eigen::Index i = 0; i < a.rows(); ++i) {
    for (Eigen::Index j = 0; j < a.cols(); ++j) {
      ASSERT_EQ(std::bit_cast<std::uint64_t>(static_cast<double>(a.derived()(i, j))),
                std::bit_cast<std::uint64_t>(static_cast<double>(b.derived()(i, j))))
          << "entry (" << i << ", " << j << ")";
    }
  }
}

// Track t of `a` and track u of `b`: the same estimate to the bit, and `same_rest(a, t, b, u)`
// checks what else the bank reports.
template <class Bank, class SameRest>
void expect_same_track(const Bank& a, std::size_t t, const Bank& b, std::size_t u,
                       SameRest&& same_rest) {
  const auto x = a.estimate(t), y = b.estimate(u);
  expect_same_bits(x.mean, y.mean);
  expect_same_bits(x.covariance, y.covariance);
  same_rest(a, t, b, u);
}

// The mode probabilities of track t of `a` and track u of `b`, to the bit.
template <class Bank>
void expect_same_mu(const Bank& a, std::size_t t, const Bank& b, std::size_t u) {
  expect_same_bits(a.mode_probabilities(t), b.mode_probabilities(u));
}

// `tracks` tracks stepped in one bank (make(tracks)) and each in a bank of its own (make(1)),
// `scans` scans of plot_of(t, k) from start_of(t): the same statuses and the same bits.
template <class Make, class Start, class Plot, class SameRest>
void expect_tracks_independent_of_their_neighbours(int tracks, int scans, Make&& make,
                                                   Start&& start_of, Plot&& plot_of,
                                                   SameRest&& same_rest) {
  const auto n = static_cast<std::size_t>(tracks);
  auto bank = make(n);
  std::vector<decltype(make(n))> alone;
  for (std::size_t t = 0; t < n; ++t) {
    bank.initialize(t, start_of(static_cast<int>(t)));
    alone.push_back(make(1));
    alone.back().initialize(0, start_of(static_cast<int>(t)));
  }
  std::vector<Eigen::Vector2d> plots(n);
  std::vector<StepStatus> status(n);
  for (int k = 0; k < scans; ++k) {
    for (std::size_t t = 0; t < n; ++t) plots[t] = plot_of(static_cast<int>(t), k);
    bank.step(plots, status);
    for (std::size_t t = 0; t < n; ++t) {
      std::vector<StepStatus> one(1);
      alone[t].step(std::span<const Eigen::Vector2d>(&plots[t], 1), one);
      ASSERT_EQ(one[0], status[t]);
      expect_same_track(bank, t, alone[t], 0, same_rest);
      if (::testing::Test::HasFatalFailure()) return;
    }
  }
}

// The same tracks in a bank of wide blocks (make(tracks, true)) and one of narrow blocks
// (make(tracks, false)): the same statuses and the same bits, scan by scan.
template <class Make, class Start, class Plot, class SameRest>
void expect_wide_blocks_as_narrow_ones(int tracks, int scans, Make&& make, Start&& start_of,
                                       Plot&& plot_of, SameRest&& same_rest) {
  const auto n = static_cast<std::size_t>(tracks);
  auto wide = make(n, true);
  auto narrow = make(n, false);
  for (std::size_t t = 0; t < n; ++t) {
    wide.initialize(t, start_of(static_cast<int>(t)));
    narrow.initialize(t, start_of(static_cast<int>(t)));
  }
  std::vector<Eigen::Vector2d> plots(n);
  std::vector<StepStatus> a(n), b(n);
  for (int k = 0; k < scans; ++k) {
    for (std::size_t t = 0; t < n; ++t) plots[t] = plot_of(static_cast<int>(t), k);
    wide.step(plots, a);
    narrow.step(plots, b);
    ASSERT_EQ(a, b);
    for (std::size_t t = 0; t < n; ++t) {
      expect_same_track(wide, t, narrow, t, same_rest);
      if (::testing::Test::HasFatalFailure()) return;
    }
  }
}

// The pack kernels of every instruction set (lane_isa.hpp: AVX-512, AVX2, the baseline; those this
// CPU runs) give the same bits: one bank per instruction set, stepped side by side.
template <class Make, class Start, class Plot, class SameRest>
void expect_instruction_sets_agree(int tracks, int scans, Make&& make, Start&& start_of,
                                   Plot&& plot_of, SameRest&& same_rest) {
  struct Uncap {
    ~Uncap() { cap_lane_isa(LaneIsa::kAvx512); }
  } uncap;
  const auto n = static_cast<std::size_t>(tracks);
  const LaneIsa isas[] = {LaneIsa::kAvx512, LaneIsa::kAvx2, LaneIsa::kBaseline};
  std::vector<decltype(make(n))> banks;
  for (std::size_t i = 0; i < 3; ++i) {
    banks.push_back(make(n));
    for (std::size_t t = 0; t < n; ++t) banks[i].initialize(t, start_of(static_cast<int>(t)));
  }
  std::vector<Eigen::Vector2d> plots(n);
  std::vector<std::vector<StepStatus>> status(3, std::vector<StepStatus>(n));
  for (int k = 0; k < scans; ++k) {
    for (std::size_t t = 0; t < n; ++t) plots[t] = plot_of(static_cast<int>(t), k);
    for (std::size_t i = 0; i < 3; ++i) {
      cap_lane_isa(isas[i]);
      banks[i].step(plots, status[i]);
    }
    for (std::size_t i = 1; i < 3; ++i) {
      ASSERT_EQ(status[0], status[i]);
      for (std::size_t t = 0; t < n; ++t) {
        expect_same_track(banks[0], t, banks[i], t, same_rest);
        if (::testing::Test::HasFatalFailure()) return;
      }
    }
  }
}

// A step of `plots` (three tracks or more) in which track 1's plot is unusable: track 0 steps
// (kOk), track 1 is refused (kInvalidMeasurement) and stays exactly as it was, and track
// `untouched`, past the stepped ones, is not touched — to the bit, `same_rest(a, t, b, u)`
// checking what else the bank reports.
template <class Bank, class SameRest>
void expect_refused_plot_keeps_the_track(Bank& bank, const std::vector<Eigen::Vector2d>& plots,
                                         std::size_t untouched, SameRest&& same_rest) {
  const Bank before = bank;
  std::vector<StepStatus> status(plots.size());
  bank.step(plots, status);
  EXPECT_EQ(status[0], StepStatus::kOk);
  EXPECT_EQ(status[1], StepStatus::kInvalidMeasurement);
  expect_same_track(bank, 1, before, 1, same_rest);
  expect_same_track(bank, untouched, before, untouched, same_rest);
}

// A bank's estimate and μ against a one-track filter's (`mean`, `covariance`, `mu`), each entry to
// `tolerance` of its scale in the state's units: a mean's 1 + its σ, a covariance entry's
// √((1 + P_aa)(1 + P_cc)) — off-diagonal entries may pass near zero, and an acceleration's
// variance is μ of its mode times the mode's, 1e-266 where that μ is — and μ's 1.
template <int N, class Mean, class Covariance>
void expect_estimate_close(const GaussianState<N>& estimate, const Mean& mean,
                           const Covariance& covariance, const ModeVector& bank_mu,
                           const ModeVector& mu, const std::string& at, double tolerance = 1e-9) {
  auto expect_close = [&](double value, double reference, double scale, const char* what) {
    EXPECT_LE(std::abs(value - reference), tolerance * (scale + std::abs(reference)))
        << at << " " << what;
  };
  for (int a = 0; a < N; ++a) {
    expect_close(estimate.mean(a), mean(a), std::sqrt(1.0 + covariance(a, a)), "mean");
    for (int c = 0; c < N; ++c) {
      expect_close(estimate.covariance(a, c), covariance(a, c),
                   std::sqrt((1.0 + covariance(a, a)) * (1.0 + covariance(c, c))), "covariance");
    }
  }
  EXPECT_EQ(bank_mu.size(), mu.size()) << at;
  for (Eigen::Index j = 0; j < std::min(bank_mu.size(), mu.size()); ++j) {
    expect_close(bank_mu(j), mu(j), 1.0, "μ");
  }
}

// `n` one-track filters, each make()'s.
template <class Make>
auto one_track_filters(std::size_t n, Make&& make) {
  std::vector<decltype(make())> out;
  out.reserve(n);
  for (std::size_t t = 0; t < n; ++t) out.push_back(make());
  return out;
}

// Tracks 0 … n − 1 of `bank` (n = single.size()) beside one-track filters (pointers to them),
// each pair started from start_of(t), then scans first … last of plot_of(t, k): the same status
// scan by scan, and compare(t, at) checks the rest (`at` names the case, scan and track). Stops at
// the first failure. Returns the number of steps refused.
template <class Bank, class Filters, class Start, class Plot, class Compare>
int follow_one_track_filters(Bank& bank, Filters& single, const std::string& name, int first,
                             int last, Start&& start_of, Plot&& plot_of, Compare&& compare) {
  const std::size_t n = single.size();
  for (std::size_t t = 0; t < n; ++t) {
    const auto start = start_of(static_cast<int>(t));
    bank.initialize(t, start);
    single[t]->initialize(start.mean, start.covariance);
  }
  std::vector<Eigen::Vector2d> plots(n);
  std::vector<StepStatus> status(n);
  int refused = 0;
  for (int k = first; k <= last; ++k) {
    for (std::size_t t = 0; t < n; ++t) plots[t] = plot_of(static_cast<int>(t), k);
    bank.step(plots, status);
    for (std::size_t t = 0; t < n; ++t) {
      const std::string at = name + " scan " + std::to_string(k) + " track " + std::to_string(t);
      EXPECT_EQ(status[t], single[t]->step(plots[t])) << at;
      if (status[t] != StepStatus::kOk) ++refused;
      compare(t, at);
      if (::testing::Test::HasFailure()) return refused;
    }
  }
  return refused;
}

// A two-axis filter's combined estimate [x, vx, y, vy] (its state and covariance).
inline GaussianState<4> two_axis_estimate(const TwoAxisFilter& filter) {
  GaussianState<4> out;
  Eigen::Vector4d variance;
  filter.state(out.mean, variance);
  filter.covariance(out.covariance);
  return out;
}

// Track t of a two-axis bank against its one-track filter (expect_estimate_close).
template <class Bank>
void expect_two_axis_close(const Bank& bank, std::size_t t, const TwoAxisFilter& filter,
                           const std::string& at, double tolerance = 1e-9) {
  const GaussianState<4> reference = two_axis_estimate(filter);
  expect_estimate_close(bank.estimate(t), reference.mean, reference.covariance,
                        bank.mode_probabilities(t), filter.mode_probabilities(), at, tolerance);
}

// The field a Bank(args…) construction is refused by; "" when it is built.
template <class Bank, class... Args>
std::string refused_field(Args&&... args) {
  return refused_field_of([&] { Bank bank(std::forward<Args>(args)...); });
}

// What every bank refuses of its caller, on a bank of 3 tracks none of which has been started:
// once track 0 is started from `start`, a step of 2 tracks (track 1 never started:
// std::logic_error), status spans of another size than the plots' (std::invalid_argument), and
// track 3 (std::out_of_range) to start or to read.
template <class Bank, class State>
void expect_refused_misuse(Bank& bank, const State& start, const Eigen::Vector2d& plot) {
  std::vector<Eigen::Vector2d> plots(2, plot);
  std::vector<StepStatus> status(2);
  bank.initialize(0, start);
  EXPECT_THROW(bank.step(plots, status), std::logic_error);
  std::vector<StepStatus> fewer(1), more(3);
  EXPECT_THROW(bank.step(plots, fewer), std::invalid_argument);
  EXPECT_THROW(bank.step(plots, more), std::invalid_argument);
  EXPECT_THROW(bank.initialize(3, start), std::out_of_range);
  EXPECT_THROW((void)bank.estimate(3), std::out_of_range);
}

// The gating matrix of `bank` against its tracks' one-track filters `single` (followed beside it
// until now; n = single.size() tracks): candidates at tracks 0, n / 2 and n − 1's predicted plots,
// 2σ and 1000σ from them and at 0.99 and 1.01 times the 99 % gate, an unusable and an
// out-of-range one; at a 99 % gate, a gate of 1e6 and none. Each entry is −∞ where the filter's
// candidate_distance after predict() exceeds the gate, else its candidate_log_likelihood, within
// `tolerance` relative (0: the same number), and NaN for the two unusable plots; a pair within
// 1e-9 relative of the gate is not judged (rounding may put it either side). Every track scores
// its own predicted plot. Leaves the filters predicted (update() or miss() next).
template <class Bank, class Filters>
void expect_gating_as_one_track_filters(Bank& bank, Filters& single, double tolerance,
                                        const std::string& name) {
  const std::size_t n = single.size();
  std::vector<Eigen::Vector2d> plots;
  for (const std::size_t t : {std::size_t{0}, n / 2, n - 1}) {
    ASSERT_EQ(single[t]->predict(), StepStatus::kOk) << name;
    Eigen::Vector2d z_hat;
    Eigen::Matrix2d S;
    ASSERT_TRUE(single[t]->predicted_plot(z_hat, S)) << name;
    const Eigen::Vector2d sigma = S.diagonal().cwiseSqrt();
    plots.insert(plots.end(), {z_hat, z_hat + 2.0 * sigma, z_hat - 1e3 * sigma});
    // Just inside and just outside the 99 % gate (bisection on the filter's own distance): a
    // distance 1 % off would put one of them on the wrong side.
    for (const double edge : {0.99, 1.01}) {
      double low = 0.0, high = 100.0;
      for (int i = 0; i < 60; ++i) {
        const double mid = 0.5 * (low + high);
        const bool beyond =
            single[t]->candidate_distance(z_hat + mid * Eigen::Vector2d(sigma.x(), -sigma.y())) >
            edge * chi_square_quantile(0.99, 2);
        (beyond ? high : low) = mid;
      }
      plots.push_back(z_hat + low * Eigen::Vector2d(sigma.x(), -sigma.y()));
    }
  }
  plots.emplace_back(std::numeric_limits<double>::quiet_NaN(), 1.0);
  plots.emplace_back(1.0, 1e300);
  const double inf = std::numeric_limits<double>::infinity();
  for (const double gate : {chi_square_quantile(0.99, 2), 1e6, inf}) {
    Eigen::MatrixXd out(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(plots.size()));
    bank.candidate_log_likelihoods(plots, gate, out);
    int inside = 0;
    for (std::size_t t = 0; t < n; ++t) {
      ASSERT_EQ(single[t]->predict(), StepStatus::kOk) << name;
      for (std::size_t q = 0; q < plots.size(); ++q) {
        const double entry = out(static_cast<Eigen::Index>(t), static_cast<Eigen::Index>(q));
        SCOPED_TRACE(name + ", track " + std::to_string(t) + ", plot " + std::to_string(q) +
                     ", gate " + std::to_string(gate));
        if (q + 2 >= plots.size()) {
          EXPECT_TRUE(std::isnan(entry)) << entry;
          continue;
        }
        const double distance = single[t]->candidate_distance(plots[q]);
        if (std::isfinite(gate) && std::abs(distance - gate) <= 1e-9 * gate) continue;
        if (distance > gate) {
          EXPECT_EQ(entry, -inf);
          continue;
        }
        const double reference = single[t]->candidate_log_likelihood(plots[q]);
        if (tolerance == 0.0) {
          EXPECT_EQ(entry, reference);
        } else {
          EXPECT_NEAR(entry, reference, tolerance * std::max(1.0, std::abs(reference)));
        }
        inside += std::isfinite(entry) ? 1 : 0;
      }
    }
    EXPECT_GE(inside, gate == inf ? static_cast<int>(n * (plots.size() - 2)) : 3)
        << name << ", gate " << gate;
  }
}

// What a bank's gating matrix refuses, after expect_refused_misuse (only track 0 started): a
// matrix of another column count than the plots or more rows than tracks (std::invalid_argument),
// a gate that is not positive (InvalidParameter("gate")), a never started track (std::logic_error).
template <class Bank>
void expect_refused_gating(Bank& bank) {
  const std::vector<Eigen::Vector2d> plots(2, Eigen::Vector2d(1.0, 2.0));
  Eigen::MatrixXd wrong(2, 3), too_many(4, 2), two(2, 2), one(1, 2);
  EXPECT_THROW(bank.candidate_log_likelihoods(plots, 9.0, wrong), std::invalid_argument);
  EXPECT_THROW(bank.candidate_log_likelihoods(plots, 9.0, too_many), std::invalid_argument);
  for (const double gate : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN()}) {
    EXPECT_EQ(refused_field_of([&] { bank.candidate_log_likelihoods(plots, gate, one); }), "gate")
        << gate;
  }
  EXPECT_THROW(bank.candidate_log_likelihoods(plots, 9.0, two), std::logic_error);
  bank.candidate_log_likelihoods(plots, 9.0, one);  // track 0 alone is asked: it answers
  EXPECT_FALSE(std::isnan(one(0, 0)));
}

// `bank` beside its one-track filters `single` for scans first … last
// (follow_one_track_filters, compare(t, at) after each), then its gating matrix against theirs
// (expect_gating_as_one_track_filters, within `tolerance`), then `after` more scans in which the
// bank still follows the filters, the first through update() with the prediction the questions
// held: asking changed no track.
template <class Bank, class Filters, class Start, class Plot, class Compare>
void expect_gating_without_changing_a_track(Bank& bank, Filters& single, const std::string& name,
                                            int first, int last, Start&& start_of, Plot&& plot_of,
                                            Compare&& compare, double tolerance, int after) {
  follow_one_track_filters(bank, single, name, first, last, start_of, plot_of, compare);
  ASSERT_FALSE(::testing::Test::HasFailure()) << name;
  expect_gating_as_one_track_filters(bank, single, tolerance, name);
  const std::size_t n = single.size();
  std::vector<Eigen::Vector2d> next(n);
  std::vector<StepStatus> status(n);
  for (int k = last + 1; k <= last + after; ++k) {
    for (std::size_t t = 0; t < n; ++t) next[t] = plot_of(static_cast<int>(t), k);
    bank.step(next, status);
    for (std::size_t t = 0; t < n; ++t) {
      const StepStatus alone =
          k == last + 1 ? single[t]->update(next[t]) : single[t]->step(next[t]);
      EXPECT_EQ(status[t], alone) << name << ", track " << t << ", scan " << k;
      compare(t, name + ", scan " + std::to_string(k) + " after asking");
    }
  }
}

}  // namespace imm::testing
