// SPDX-License-Identifier: Apache-2.0
// The banks' IMM cycle written once over a number type and a filter family (imm_cycle.hpp), with
// a small family of its own here (one coordinate, a random walk per mode): its pack instance
// against its double instance, lane by lane, to the bit; one track's modes in one pack against the
// mode loop, to the bit; K packs together against K alone and the
// unrolled mode count against the general loop, to the bit; against a textbook IMM in linear
// probabilities (eq. 4–11 of seed 000) written out below; what a lane that fails keeps and says;
// the banks' NIS of a diagonal S against normalized_innovation_squared, to the bit.
#include "tracking/imm_cycle.hpp"

// 64-byte vectors by value in the test (lane_math.hpp says why that is harmless).
#pragma GCC diagnostic ignored "-Wpsabi"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm/tracking/track_filter.hpp"

namespace imm::bank {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// One coordinate x with variance p, mode j a random walk with noise q_j, plots of variance r. A
// mode also counts its committed steps (an entry of its own, which the mixing does not read).
struct RandomWalkFamily {
  static constexpr int kEntries = 3, kCombined = 2;
  template <class S>
  using Plot = S;
  std::array<double, kMaxModes> q{};
  double r = 1.0;

  template <class S, class Modes>
  void mix(int n, const S* w, Modes&& mode, std::array<S, kCombined>& out) const {
    S m = splat<S>(0.0);
    for (int i = 0; i < n; ++i) m += w[i] * mode(i)[0];
    S c = splat<S>(0.0);
    for (int i = 0; i < n; ++i) {
      const S d = mode(i)[0] - m;
      c += w[i] * (mode(i)[1] + d * d);
    }
    out = {m, c};
  }

  template <class S, int K>
  void steps(int j, const std::array<S, kCombined> (&mixed)[K],
             const std::array<S, kEntries> (&current)[K], const S (&z)[K],
             std::array<S, kEntries> (&updated)[K], S (&log_likelihood)[K], S (&code)[K]) const {
    for (int k = 0; k < K; ++k) {
      step(q[static_cast<std::size_t>(j)], mixed[k], current[k], z[k], updated[k],
           log_likelihood[k], code[k]);
    }
  }

  // The n modes of one track at once, mode j in lane j (the cycle's one-track path).
  template <class P>
  void steps_across_modes(int n, const std::array<P, kCombined>& mixed,
                          const std::array<P, kEntries>& current, const double& z,
                          std::array<P, kEntries>& updated, P& log_likelihood, P& code) const {
    double lanes[kLanesOf<P>];
    for (int j = 0; j < kLanesOf<P>; ++j) lanes[j] = q[static_cast<std::size_t>(j < n ? j : 0)];
    step(lane_load<P>(lanes), mixed, current, splat<P>(z), updated, log_likelihood, code);
  }

  template <class S, class Q>
  void step(const Q& noise, const std::array<S, kCombined>& mixed,
            const std::array<S, kEntries>& current, const S& z, std::array<S, kEntries>& updated,
            S& log_likelihood, S& code) const {
    const S p = mixed[1] + noise;
    const S s = p + r;
    const S gain = p / s, nu = z - mixed[0], rest = 1.0 - gain;
    updated = {mixed[0] + gain * nu, rest * rest * p + gain * gain * r, current[2] + 1.0};
    log_likelihood = -0.5 * (nu * nu / s + lane_log(s) + kLogTwoPi);
    const S zeros = updated[0] * 0.0 + updated[1] * 0.0;
    code = pick(s > 0.0, pick(s < kInf, pick(zeros == 0.0, kOk, kNonFinite), kSingular), kSingular);
  }

  template <class S>
  S track_code(S code) const {
    return code;
  }
};
using Slots = CycleSlots<RandomWalkFamily>;

// A bank's state of `lanes` lanes of an n-mode IMM: slots `lanes` apart.
struct Bank {
  int modes = 0, lanes = 0;
  std::vector<double> transition, log_transition, state;
  Bank(int n, int lane_count, const std::vector<double>& pi) : modes(n), lanes(lane_count) {
    transition = pi;
    for (double p : pi) log_transition.push_back(p > 0.0 ? std::log(p) : -kInf);
    state.assign(static_cast<std::size_t>((n * Slots::kModeSlots + 2) * lane_count), 0.0);
  }
  double& at(int slot, int lane) { return state[static_cast<std::size_t>(slot * lanes + lane)]; }
  CycleBlock block() {
    return {modes, transition.data(), log_transition.data(), state.data(), lanes};
  }
  // Lane `lane` from log μ and the modes' (x, p): μ̃ = μ / max μ, the combined estimate.
  void start(int lane, const std::vector<double>& log_mu, const std::vector<double>& x,
             const std::vector<double>& p) {
    double top = -kInf;
    for (double v : log_mu) top = std::max(top, v);
    double m = 0.0, c = 0.0;
    for (int j = 0; j < modes; ++j) {
      const auto u = static_cast<std::size_t>(j);
      at(j * Slots::kModeSlots, lane) = x[u];
      at(j * Slots::kModeSlots + 1, lane) = p[u];
      at(j * Slots::kModeSlots + 2, lane) = 0.0;
      at(j * Slots::kModeSlots + Slots::kLogMu, lane) = log_mu[u];
      at(j * Slots::kModeSlots + Slots::kScaledMu, lane) = std::exp(log_mu[u] - top);
      m += std::exp(log_mu[u]) * x[u];
    }
    for (int j = 0; j < modes; ++j) {
      const auto u = static_cast<std::size_t>(j);
      c += std::exp(log_mu[u]) * (p[u] + (x[u] - m) * (x[u] - m));
    }
    at(modes * Slots::kModeSlots, lane) = m;
    at(modes * Slots::kModeSlots + 1, lane) = c;
  }
  // Lane `lane` alone, as a bank of one lane.
  Bank lane(int l) const {
    Bank one(modes, 1, transition);
    for (int s = 0; s < modes * Slots::kModeSlots + 2; ++s)
      one.state[static_cast<std::size_t>(s)] = state[static_cast<std::size_t>(s * lanes + l)];
    return one;
  }
};

bool same(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

// Modes of noise q (per scan), plots of variance r.
RandomWalkFamily random_walks(std::initializer_list<double> q, double r) {
  RandomWalkFamily f;
  std::copy(q.begin(), q.end(), f.q.begin());
  f.r = r;
  return f;
}

// Three modes, noise from 10⁻⁴ to 10 per scan; Π with strong diagonal.
RandomWalkFamily three_modes() { return random_walks({1e-4, 0.1, 10.0}, 0.5); }
const std::vector<double> kPi3 = {0.90, 0.07, 0.03, 0.05, 0.90, 0.05, 0.02, 0.08, 0.90};

// A bank of `lanes` lanes in random states: log μ, means and variances far apart now and then.
Bank random_bank(int lanes, std::mt19937_64& rng) {
  Bank b(3, lanes, kPi3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int l = 0; l < lanes; ++l) {
    std::vector<double> log_mu(3), x(3), p(3);
    for (int j = 0; j < 3; ++j) {
      const auto s = static_cast<std::size_t>(j);
      log_mu[s] = 30.0 * (u(rng) - 1.0);  // down to e⁻⁶⁰
      x[s] = 5.0 * u(rng);
      p[s] = std::pow(10.0, 3.0 * u(rng));
    }
    double top = -kInf;
    for (double v : log_mu) top = std::max(top, v);
    double sum = 0.0;
    for (double v : log_mu) sum += std::exp(v - top);
    for (double& v : log_mu) v = (v - top) - std::log(sum);
    b.start(l, log_mu, x, p);
  }
  return b;
}

// Runs one cycle of b's lanes [first, first + K · kLanesOf<S>) with plots z.
template <class S, int N, int K>
std::vector<double> run(const RandomWalkFamily& f, Bank& b, int first, const double* z,
                        const double* usable, const double* stepped) {
  constexpr int kLanes = kLanesOf<S>;
  S plot[K], use[K], step[K];
  for (int k = 0; k < K; ++k) {
    plot[k] = lane_load<S>(z + k * kLanes);
    use[k] = lane_load<S>(usable + k * kLanes);
    step[k] = lane_load<S>(stepped + k * kLanes);
  }
  std::vector<double> code(static_cast<std::size_t>(K * kLanes));
  imm_cycle<S, N, K>(f, b.block(), first, plot, use, step, code.data());
  return code;
}

// A mode's slots, as the cycle reads them: mode j's three entries, its log μ and μ̃, then mode
// j + 1's; the combined estimate after the last mode.
TEST(ImmCycle, AModesSlotsAreItsEntriesThenLogMuAndScaledMu) {
  Bank bank(3, 1, std::vector<double>(9, 1.0 / 3.0));
  const CycleBlock b = bank.block();
  EXPECT_EQ(imm_mode_slot(0, 3, 0), 0);
  EXPECT_EQ(imm_mode_slot(1, 3, 0), 5);
  EXPECT_EQ(imm_mode_slot(2, 3, 4), 14);
  EXPECT_EQ(Slots::kModeSlots, 5);
  EXPECT_EQ(Slots::at(b, 1, Slots::kLogMu, 0), &bank.at(8, 0));
  EXPECT_EQ(Slots::at(b, 2, Slots::kScaledMu, 0), &bank.at(14, 0));
  EXPECT_EQ(Slots::at(b, 3, 1, 0), &bank.at(16, 0));
}

TEST(ImmCycle, EveryLaneOfAPackEqualsTheDoubleInstanceToTheBit) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, 3.0);
  const RandomWalkFamily f = three_modes();
  for (int trial = 0; trial < 200; ++trial) {
    Bank pack = random_bank(kLanePackWidth, rng);
    std::vector<Bank> alone;
    for (int l = 0; l < kLanePackWidth; ++l) alone.push_back(pack.lane(l));
    for (int scan = 0; scan < 5; ++scan) {
      double z[kLanePackWidth], usable[kLanePackWidth], stepped[kLanePackWidth];
      for (int l = 0; l < kLanePackWidth; ++l) {
        z[l] = noise(rng) * (trial % 7 == 0 ? 1e3 : 1.0);
        usable[l] = (trial + l + scan) % 11 == 0 ? 0.0 : 1.0;
        stepped[l] = (trial + 3 * l) % 13 == 0 ? 0.0 : 1.0;
      }
      const auto codes = run<LanePack, 3, 1>(f, pack, 0, z, usable, stepped);
      for (int l = 0; l < kLanePackWidth; ++l) {
        const auto code = run<double, 3, 1>(f, alone[static_cast<std::size_t>(l)], 0, z + l,
                                            usable + l, stepped + l);
        ASSERT_TRUE(same(codes[static_cast<std::size_t>(l)], code[0]))
            << "trial " << trial << " lane " << l;
        const Bank& one = alone[static_cast<std::size_t>(l)];
        for (int s = 0; s < 3 * Slots::kModeSlots + 2; ++s) {
          ASSERT_TRUE(same(pack.at(s, l), one.state[static_cast<std::size_t>(s)]))
              << "trial " << trial << " lane " << l << " slot " << s;
        }
      }
    }
  }
}

TEST(ImmCycle, PacksTakenTogetherAndTheGeneralModeLoopGiveTheSameBits) {
  std::mt19937_64 rng(12);
  std::normal_distribution<double> noise(0.0, 3.0);
  const RandomWalkFamily f = three_modes();
  constexpr int kW = 2 * kLanePackWidth;
  const Bank start = random_bank(kW, rng);
  Bank together = start, apart = start, general = start;
  for (int scan = 0; scan < 20; ++scan) {
    double z[kW], usable[kW], stepped[kW];
    for (int l = 0; l < kW; ++l) {
      z[l] = noise(rng);
      usable[l] = (l + scan) % 9 == 0 ? 0.0 : 1.0;
      stepped[l] = 1.0;
    }
    const auto a = run<LanePack, 3, 2>(f, together, 0, z, usable, stepped);
    auto b = run<LanePack, 3, 1>(f, apart, 0, z, usable, stepped);
    const auto b2 = run<LanePack, 3, 1>(f, apart, kLanePackWidth, z + kLanePackWidth,
                                        usable + kLanePackWidth, stepped + kLanePackWidth);
    b.insert(b.end(), b2.begin(), b2.end());
    const auto c = run<LanePack, kMaxModes, 2>(f, general, 0, z, usable, stepped);
    for (std::size_t i = 0; i < a.size(); ++i) {
      ASSERT_TRUE(same(a[i], b[i]) && same(a[i], c[i]));
    }
    for (std::size_t i = 0; i < start.state.size(); ++i) {
      ASSERT_TRUE(same(together.state[i], apart.state[i]) &&
                  same(together.state[i], general.state[i]))
          << "scan " << scan << " value " << i;
    }
  }
}

// One track's modes in the lanes of one pack (the double instance with 2 to 8 modes known at
// compile time: steps_across_modes) against the general mode loop (kMaxModes), to the bit: through
// a mode that fails, refused plots, plots so far that every likelihood underflows, and a Π whose
// zeros leave a mode unreachable (c̃_j = 0: the exact fallback).
template <int N>
void expect_modes_in_lanes_to_equal_the_mode_loop(std::uint64_t seed, std::vector<double>& seen) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 3.0);
  for (int trial = 0; trial < 40; ++trial) {
    RandomWalkFamily f;
    for (std::size_t j = 0; j < N; ++j) f.q[j] = std::pow(10.0, 4.0 * u(rng) - 3.0);
    if (trial % 5 == 1) f.q[N - 1] = kInf;  // S not finite: singular
    f.r = 0.5;
    const bool unreachable = trial % 3 == 2;  // mode N − 1: no mode moves to it, μ = 0
    const int reachable = unreachable ? N - 1 : N;
    std::vector<double> pi(static_cast<std::size_t>(N * N), 0.0);
    for (int i = 0; i < N; ++i) {
      double* row = pi.data() + static_cast<std::ptrdiff_t>(i) * N;
      double total = 0.0;
      for (int j = 0; j < reachable; ++j) total += row[j] = u(rng);
      for (int j = 0; j < reachable; ++j) row[j] /= total;
    }
    if (unreachable) pi[static_cast<std::size_t>(N * N - 1)] = 1.0;
    std::vector<double> log_mu(N), x(N), p(N);
    for (std::size_t j = 0; j < N; ++j) {
      log_mu[j] = 30.0 * (u(rng) - 1.0);
      x[j] = 10.0 * u(rng) - 5.0;
      p[j] = std::pow(10.0, 6.0 * u(rng) - 3.0);
    }
    if (unreachable) log_mu[N - 1] = -kInf;
    const double top = *std::max_element(log_mu.begin(), log_mu.end());
    double sum = 0.0;
    for (double v : log_mu) sum += std::exp(v - top);
    for (double& v : log_mu) v = (v - top) - std::log(sum);
    Bank lanes(N, 1, pi);
    lanes.start(0, log_mu, x, p);
    Bank loop = lanes;
    for (int scan = 0; scan < 8; ++scan) {
      const double z = scan == 5 ? 1e200 : noise(rng) * (trial % 7 == 0 ? 1e3 : 1.0);
      const double usable = (trial + scan) % 6 == 0 ? 0.0 : 1.0, stepped = 1.0;
      const auto a = run<double, N, 1>(f, lanes, 0, &z, &usable, &stepped);
      const auto b = run<double, kMaxModes, 1>(f, loop, 0, &z, &usable, &stepped);
      ASSERT_TRUE(same(a[0], b[0])) << N << " modes, trial " << trial << " scan " << scan;
      seen.push_back(a[0]);
      for (std::size_t i = 0; i < lanes.state.size(); ++i) {
        ASSERT_TRUE(same(lanes.state[i], loop.state[i]))
            << N << " modes, trial " << trial << " scan " << scan << " value " << i;
      }
    }
  }
}

TEST(ImmCycle, OneTracksModesInOnePackEqualTheModeLoopToTheBit) {
  std::vector<double> seen;
  seen.reserve(1600);  // five mode counts, 40 trials, 8 scans
  expect_modes_in_lanes_to_equal_the_mode_loop<2>(21, seen);
  expect_modes_in_lanes_to_equal_the_mode_loop<3>(22, seen);
  expect_modes_in_lanes_to_equal_the_mode_loop<4>(23, seen);
  expect_modes_in_lanes_to_equal_the_mode_loop<5>(24, seen);
  expect_modes_in_lanes_to_equal_the_mode_loop<8>(25, seen);
  // Every outcome was there.
  for (double code : {kOk, kSingular, kUnderflow, kBadPlot})
    EXPECT_NE(std::find(seen.begin(), seen.end(), code), seen.end()) << code;
}

// The textbook IMM of the same family, linear probabilities, in plain loops.
struct Textbook {
  std::vector<double> mu, x, p;
  double combined_x = 0.0, combined_p = 0.0;
  void cycle(const RandomWalkFamily& f, const std::vector<double>& pi, double z) {
    const std::size_t n = mu.size();
    std::vector<double> c(n, 0.0), nx(n), np(n), likelihood(n);
    for (std::size_t j = 0; j < n; ++j) {
      for (std::size_t i = 0; i < n; ++i) c[j] += pi[i * n + j] * mu[i];
    }
    for (std::size_t j = 0; j < n; ++j) {
      double m = x[j], v = p[j];  // an unreachable mode (c_j = 0) keeps its own estimate
      if (c[j] > 0.0) {
        m = 0.0;
        v = 0.0;
        for (std::size_t i = 0; i < n; ++i) m += pi[i * n + j] * mu[i] / c[j] * x[i];
        for (std::size_t i = 0; i < n; ++i)
          v += pi[i * n + j] * mu[i] / c[j] * (p[i] + (x[i] - m) * (x[i] - m));
      }
      const double predicted = v + f.q[j], s = predicted + f.r, gain = predicted / s;
      nx[j] = m + gain * (z - m);
      np[j] = (1.0 - gain) * (1.0 - gain) * predicted + gain * gain * f.r;
      likelihood[j] =
          std::exp(-0.5 * (z - m) * (z - m) / s) / std::sqrt(2.0 * std::numbers::pi * s);
    }
    double total = 0.0;
    for (std::size_t j = 0; j < n; ++j) total += likelihood[j] * c[j];
    for (std::size_t j = 0; j < n; ++j) mu[j] = likelihood[j] * c[j] / total;
    x = nx;
    p = np;
    combined_x = 0.0;
    combined_p = 0.0;
    for (std::size_t j = 0; j < n; ++j) combined_x += mu[j] * x[j];
    for (std::size_t j = 0; j < n; ++j)
      combined_p += mu[j] * (p[j] + (x[j] - combined_x) * (x[j] - combined_x));
  }
};

void expect_close(double a, double b, const char* what, int scan) {
  EXPECT_NEAR(a, b, 1e-11 * std::max(1.0, std::abs(b))) << what << " at scan " << scan;
}

// A target that stands, then moves, then stands: the modes take turns.
void expect_textbook(const RandomWalkFamily& f, const std::vector<double>& pi,
                     const std::vector<double>& mu) {
  const int n = static_cast<int>(mu.size());
  Bank bank(n, 1, pi);
  std::vector<double> log_mu;
  for (double v : mu) log_mu.push_back(v > 0.0 ? std::log(v) : -kInf);
  Textbook book{mu, std::vector<double>(mu.size(), 1.0), std::vector<double>(mu.size(), 4.0)};
  bank.start(0, log_mu, book.x, book.p);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, std::sqrt(f.r));
  double truth = 1.0;
  for (int scan = 1; scan <= 60; ++scan) {
    if (scan > 20 && scan <= 40) truth += 2.5;
    const double z = truth + noise(rng);
    const double one = 1.0;
    const auto code = run<double, kMaxModes, 1>(f, bank, 0, &z, &one, &one);
    ASSERT_EQ(code[0], kOk);
    book.cycle(f, pi, z);
    for (int j = 0; j < n; ++j) {
      const auto u = static_cast<std::size_t>(j);
      const double log_mu_j = bank.at(j * Slots::kModeSlots + Slots::kLogMu, 0);
      expect_close(std::exp(log_mu_j), book.mu[u], "μ", scan);
      if (book.mu[u] > 1e-300) {
        expect_close(bank.at(j * Slots::kModeSlots, 0), book.x[u], "mode x", scan);
        expect_close(bank.at(j * Slots::kModeSlots + 1, 0), book.p[u], "mode p", scan);
      }
      EXPECT_EQ(bank.at(j * Slots::kModeSlots + 2, 0), scan);  // the mode's own entry
    }
    expect_close(bank.at(n * Slots::kModeSlots, 0), book.combined_x, "x", scan);
    expect_close(bank.at(n * Slots::kModeSlots + 1, 0), book.combined_p, "p", scan);
  }
}

TEST(ImmCycle, EqualsTheTextbookImm) {
  expect_textbook(three_modes(), kPi3, {0.6, 0.3, 0.1});
  expect_textbook(random_walks({0.01, 4.0}, 2.0), {0.95, 0.05, 0.10, 0.90}, {1.0, 0.0});
}

// Π with zeros and a mode of probability 0 that no mode can reach: c̃_j underflows to 0, the exact
// fallback gives log c_j = −∞, and the mode keeps its own estimate with μ_j = 0 (ImmEstimator).
TEST(ImmCycle, AnUnreachableModeKeepsItsOwnEstimateAndProbabilityZero) {
  expect_textbook(random_walks({0.01, 1.0}, 1.0), {1.0, 0.0, 0.3, 0.7}, {1.0, 0.0});
}

TEST(ImmCycle, ALaneThatFailsKeepsItsStateAndSaysWhy) {
  std::mt19937_64 rng(13);
  RandomWalkFamily f = three_modes();
  f.q[1] = kInf;  // mode 1's S is not finite: singular, though mode 0 succeeds
  Bank b = random_bank(kLanePackWidth, rng);
  const Bank before = b;
  double z[kLanePackWidth] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  double usable[kLanePackWidth] = {1.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0};
  const double stepped[kLanePackWidth] = {1.0, 1.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0};
  auto codes = run<LanePack, 3, 1>(f, b, 0, z, usable, stepped);
  EXPECT_EQ(codes[0], kSingular);
  EXPECT_EQ(codes[1], kBadPlot);  // the plot decides before the modes
  for (double v : codes) EXPECT_NE(v, kOk);
  for (std::size_t i = 0; i < b.state.size(); ++i) ASSERT_TRUE(same(b.state[i], before.state[i]));

  // Every likelihood underflows for a plot 10²⁰⁰ away (ν² overflows): kUnderflow, nothing changes.
  f = three_modes();
  for (double& v : z) v = 1e200;
  codes = run<LanePack, 3, 1>(f, b, 0, z, usable, stepped);
  EXPECT_EQ(codes[0], kUnderflow);
  for (std::size_t i = 0; i < b.state.size(); ++i) ASSERT_TRUE(same(b.state[i], before.state[i]));

  // A usable plot and every lane stepped: all commit; a lane with stepped 0 computes but keeps.
  for (double& v : z) v = 0.5;
  for (double& v : usable) v = 1.0;
  codes = run<LanePack, 3, 1>(f, b, 0, z, usable, stepped);
  for (int l = 0; l < kLanePackWidth; ++l) {
    EXPECT_EQ(codes[static_cast<std::size_t>(l)], kOk) << l;
    const bool changed = b.at(0, l) != before.state[static_cast<std::size_t>(l)];
    EXPECT_EQ(changed, stepped[l] != 0.0) << l;
  }
}

// diagonal_nis (axis_lane_bank.hpp), the NIS the axis banks state, is what
// normalized_innovation_squared gives for S = diag(s_x, s_y) to the bit: over magnitudes from
// 1e-12 to 1e12, and NaN where that refuses S (a variance ≤ 0) or gives NaN.
TEST(ImmCycle, TheNisOfADiagonalSIsNormalizedInnovationSquaredToTheBit) {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> exponent(-12.0, 12.0), sign(-1.0, 1.0);
  auto draw = [&] { return std::copysign(std::pow(10.0, exponent(rng)), sign(rng)); };
  auto expect_same = [](double nx, double ny, double sx, double sy) {
    const auto reference = normalized_innovation_squared(Eigen::Vector2d(nx, ny),
                                                         Eigen::Matrix2d{{sx, 0.0}, {0.0, sy}});
    const double value = diagonal_nis(nx, ny, sx, sy);
    if (!reference || std::isnan(*reference)) {
      EXPECT_TRUE(std::isnan(value)) << nx << " " << ny << " " << sx << " " << sy;
    } else {
      EXPECT_EQ(std::bit_cast<std::uint64_t>(value), std::bit_cast<std::uint64_t>(*reference))
          << nx << " " << ny << " " << sx << " " << sy;
    }
  };
  for (int i = 0; i < 100000; ++i) {
    expect_same(draw(), draw(), std::abs(draw()), std::abs(draw()));
    if (HasFailure()) return;
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const double s : {0.0, -1.0, -0.0, nan, kInf}) {
    expect_same(1.5, -2.0, s, 2.0);
    expect_same(1.5, -2.0, 2.0, s);
  }
  expect_same(0.0, 0.0, 1.0, 1.0);
  expect_same(kInf, 1.0, 1.0, 1.0);
  expect_same(nan, 1.0, 1.0, 1.0);
}

}  // namespace
}  // namespace imm::bank
