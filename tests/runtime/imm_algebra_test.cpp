// SPDX-License-Identifier: Apache-2.0
// The IMM's own arithmetic written once over a number type (imm/estimation/imm_algebra.hpp):
// against the textbook IMM written out in linear probabilities (Blom & Bar-Shalom, seed 000
// eq. 4–11), a Gaussian mixture's moments by their other closed form, the exact fallback where a
// predicted probability underflows, and its pack instance against its double instance, lane by
// lane, to the bit.
#include "imm/estimation/imm_algebra.hpp"

// 64-byte vectors by value in the test (lane_math.hpp says why that is harmless).
#pragma GCC diagnostic ignored "-Wpsabi"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>

#include "imm/math/lane_math.hpp"

namespace imm::algebra {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// A random row-stochastic Π of n modes, every entry at least `floor`.
Eigen::MatrixXd random_transition(int n, std::mt19937_64& rng, double floor = 0.01) {
  std::uniform_real_distribution<double> u(floor, 1.0);
  Eigen::MatrixXd p(n, n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) p(i, j) = u(rng);
    p.row(i) /= p.row(i).sum();
  }
  return p;
}

TEST(ImmAlgebra, PredictedProbabilitiesAndWeightsAreTheMarkovChainsInLinearSpace) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.05, 1.0);
  for (int n : {1, 2, 3, 5, 8}) {
    const Eigen::MatrixXd p = random_transition(n, rng);
    Eigen::VectorXd mu(n);
    for (int i = 0; i < n; ++i) mu(i) = u(rng);
    mu /= mu.sum();
    std::array<double, 8> log_mu{}, scaled{}, predicted{}, log_c{};
    for (int i = 0; i < n; ++i) log_mu[i] = std::log(mu(i));
    std::array<double, 64> weights{};
    auto run = [&](auto functions, auto division) {
      using Fn = decltype(functions);
      const double shift = scaled_probabilities<Fn>(n, log_mu, scaled);
      predict_probabilities<Fn, decltype(division)::value>(
          n, [&p](int i, int j) { return p(i, j); }, scaled, shift, predicted, log_c,
          weights.data());
      EXPECT_FALSE(needs_exact_prediction(n, predicted));
      for (int j = 0; j < n; ++j) {
        // c_j = Σ_i p_ij μ_i and μ_ij = p_ij μ_i / c_j (eq. 6).
        double c = 0.0;
        for (int i = 0; i < n; ++i) c += p(i, j) * mu(i);
        EXPECT_NEAR(std::exp(log_c[j]), c, 1e-14 * c) << "n " << n << " j " << j;
        double total = 0.0;
        for (int i = 0; i < n; ++i) {
          EXPECT_NEAR(weights[j * n + i], p(i, j) * mu(i) / c, 1e-14) << "n " << n;
          total += weights[j * n + i];
        }
        EXPECT_NEAR(total, 1.0, 1e-15 * n);
      }
    };
    run(LibmFunctions{}, std::integral_constant<Division, Division::kDivide>{});
    run(LaneFunctions{}, std::integral_constant<Division, Division::kInverse>{});
  }
}

TEST(ImmAlgebra, ThePosteriorIsBayesRuleInLogSpaceAndSurvivesFarOffLikelihoods) {
  // μ_j ∝ Λ_j c_j (eq. 8–9): log μ_j = v_j − log Σ exp(v_k) with v_j = ℓ_j + log c_j.
  const std::array<double, 3> v = {-2.5, -0.25, -7.0};
  std::array<double, 3> centered = v, scaled{};
  double sum = 0.0, log_sum = 0.0;
  const double top = posterior<LibmFunctions>(3, centered, scaled, sum, log_sum);
  EXPECT_EQ(top, -0.25);
  const double normalizer = std::log(std::exp(-2.5) + std::exp(-0.25) + std::exp(-7.0));
  for (int j = 0; j < 3; ++j) {
    EXPECT_NEAR(centered[j] - log_sum, v[j] - normalizer, 1e-15);
    EXPECT_NEAR(scaled[j] / sum, std::exp(v[j] - normalizer), 1e-15);
  }
  // A plot many σ away: ℓ ≈ −1e30. The top mode gets log μ = 0 exactly, the other −3e29, not two
  // modes of log μ = 0 (as −1e30 − (−1e30 + log Σ) would round to).
  std::array<double, 2> far = {-1e30, -1.3e30}, far_scaled{};
  EXPECT_EQ(posterior<LaneFunctions>(2, far, far_scaled, sum, log_sum), -1e30);
  EXPECT_EQ(far[0] - log_sum, 0.0);
  EXPECT_DOUBLE_EQ(far[1] - log_sum, -3e29);
  EXPECT_EQ(far_scaled[1], 0.0);
  // Every likelihood underflowed: the top is not finite, which the caller reports.
  std::array<double, 2> none = {-kInf, -kInf}, none_scaled{};
  EXPECT_FALSE(std::isfinite(posterior<LibmFunctions>(2, none, none_scaled, sum, log_sum)));
}

TEST(ImmAlgebra, LogSumExpIsAMixturesLogDensityAndSurvivesFarOffComponents) {
  // log(e^a + e^b + e^c) by the closed form.
  const std::array<double, 3> v = {-2.5, -0.25, -7.0};
  const double expected = std::log(std::exp(-2.5) + std::exp(-0.25) + std::exp(-7.0));
  EXPECT_NEAR(log_sum_exp<LibmFunctions>(3, v), expected, 1e-15);
  EXPECT_NEAR(log_sum_exp<LaneFunctions>(3, v), expected, 1e-15);
  // Only the first n entries count.
  EXPECT_NEAR(log_sum_exp<LibmFunctions>(2, v), std::log(std::exp(-2.5) + std::exp(-0.25)), 1e-15);
  // Components far out in the tail (where exp of each underflows): the largest plus log 1 + e^−Δ.
  const std::array<double, 2> far = {-1e3, -1e3 - std::log(3.0)};
  EXPECT_NEAR(log_sum_exp<LaneFunctions>(2, far), -1e3 + std::log(4.0 / 3.0), 1e-12);
  // A component of −∞ contributes nothing; every component −∞ gives −∞, not NaN.
  const std::array<double, 2> one = {-kInf, -4.0};
  EXPECT_EQ(log_sum_exp<LaneFunctions>(2, one), -4.0);
  const std::array<double, 2> none = {-kInf, -kInf};
  EXPECT_EQ(log_sum_exp<LibmFunctions>(2, none), -kInf);
  EXPECT_EQ(log_sum_exp<LaneFunctions>(2, none), -kInf);
}

TEST(ImmAlgebra, TheExactFallbackTakesAnUnderflowedPredictionAndAnUnreachableMode) {
  // Mode 1 is reached only from itself, and its μ is e^−800: c̃_1 = p_11 μ̃_1 underflows to 0 in
  // the scaled sum, while log c_1 = log p_11 − 800 is finite. Mode 3 is reached from nowhere.
  const int n = 4;
  Eigen::MatrixXd p(n, n);
  p << 0.9, 0.0, 0.1, 0.0,  //
      0.0, 0.5, 0.5, 0.0,   //
      0.2, 0.0, 0.8, 0.0,   //
      0.3, 0.0, 0.7, 0.0;
  const std::array<double, 4> log_mu = {std::log(0.6), -800.0, std::log(0.4), -kInf};
  std::array<double, 4> scaled{}, predicted{}, log_c{};
  std::array<double, 16> weights{};
  auto log_p = [&p](int i, int j) { return p(i, j) > 0.0 ? std::log(p(i, j)) : -kInf; };
  const double shift = scaled_probabilities<LibmFunctions>(n, log_mu, scaled);
  predict_probabilities<LibmFunctions, Division::kDivide>(
      n, [&p](int i, int j) { return p(i, j); }, scaled, shift, predicted, log_c, weights.data());
  EXPECT_EQ(predicted[1], 0.0);
  EXPECT_EQ(predicted[3], 0.0);
  ASSERT_TRUE(needs_exact_prediction(n, predicted));
  exact_prediction(n, log_p, log_mu, predicted, log_c, weights.data());
  EXPECT_NEAR(log_c[1], std::log(0.5) - 800.0, 1e-12);
  for (int i = 0; i < n; ++i) EXPECT_EQ(weights[1 * n + i], i == 1 ? 1.0 : 0.0);
  // c_3 = 0: unreachable, and it keeps its own estimate (weights δ_i3).
  EXPECT_EQ(log_c[3], -kInf);
  for (int i = 0; i < n; ++i) EXPECT_EQ(weights[3 * n + i], i == 3 ? 1.0 : 0.0);
  // The reachable columns are untouched by the fallback and sum to 1.
  for (int j : {0, 2}) {
    EXPECT_NEAR(std::exp(log_c[j]), 0.6 * p(0, j) + 0.4 * p(2, j), 1e-15) << j;
    double total = 0.0;
    for (int i = 0; i < n; ++i) total += weights[j * n + i];
    EXPECT_NEAR(total, 1.0, 1e-15) << j;
  }
}

TEST(ImmAlgebra, TheLargestPassesOverNaNAndKeepsTheFirstOfEqualsForADoubleAsForAPack) {
  // A double's running maximum is a `?:` (one maxsd), a pack's a select of masks: the same value,
  // a NaN passed over and the first of two equal values (−0 before +0) kept, for one track as
  // for every lane.
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  const std::array<std::array<double, 3>, 5> cases = {{{kNaN, 1.0, -2.0},
                                                       {-2.0, kNaN, 1.0},
                                                       {-0.0, 0.0, -kInf},
                                                       {-kInf, -kInf, -kInf},
                                                       {kNaN, kNaN, kNaN}}};
  using P = LanePackOf<8>;
  for (const auto& values : cases) {
    const double top = largest<double>(3, values);
    std::array<P, 3> packs{};
    for (int j = 0; j < 3; ++j) packs[j] = splat<P>(values[j]);
    const Lanes<P> lanes = lanes_of(largest<P>(3, packs));
    for (double lane : lanes) {
      EXPECT_EQ(std::bit_cast<std::uint64_t>(lane), std::bit_cast<std::uint64_t>(top));
    }
  }
  EXPECT_EQ(largest<double>(3, cases[0]), 1.0);
  EXPECT_TRUE(std::signbit(largest<double>(3, cases[2])));
  EXPECT_EQ(largest<double>(3, cases[4]), -kInf);
}

TEST(ImmAlgebra, TheCollapseIsTheMixturesMomentsByTheirOtherClosedForm) {
  // P = Σ w_i (P_i + m_i m_iᵀ) − m mᵀ, the second moment less the mean's square: another
  // arrangement of eq. 5's sum, equal to rounding.
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g;
  constexpr int D = 3, kComponents = 4;
  const int n = kComponents;
  std::array<Eigen::Vector3d, kComponents> m;
  std::array<Eigen::Matrix3d, kComponents> P;
  std::array<double, kComponents> w = {0.1, 0.0, 0.6, 0.3};
  for (int i = 0; i < n; ++i) {
    m[i] = Eigen::Vector3d::NullaryExpr([&] { return g(rng); });
    const Eigen::Matrix3d a = Eigen::Matrix3d::NullaryExpr([&] { return g(rng); });
    P[i] = a * a.transpose() + Eigen::Matrix3d::Identity();
  }
  // The zero-weight component holds NaN: it must add nothing.
  m[1].setConstant(std::numeric_limits<double>::quiet_NaN());
  P[1].setConstant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d mean;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Entries entries : {Entries::kUpper, Entries::kAll}) {
    auto run = [&](auto kind) {
      collapse<D, double, decltype(kind)::value>(
          n, [&w](int i) { return w[i]; }, [&m](int i, int a) { return m[i](a); },
          [&P](int i, int a, int c) { return P[i](a, c); },
          [&mean](int a) -> double& { return mean(a); },
          [&covariance](int a, int c) -> double& { return covariance(a, c); });
    };
    if (entries == Entries::kUpper) {
      run(std::integral_constant<Entries, Entries::kUpper>{});
    } else {
      run(std::integral_constant<Entries, Entries::kAll>{});
    }
    Eigen::Vector3d expected_mean = Eigen::Vector3d::Zero();
    Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
    for (int i = 0; i < n; ++i) {
      if (w[i] == 0.0) continue;
      expected_mean += w[i] * m[i];
      second += w[i] * (P[i] + m[i] * m[i].transpose());
    }
    const Eigen::Matrix3d expected = second - expected_mean * expected_mean.transpose();
    EXPECT_TRUE(mean.allFinite());
    EXPECT_LT((mean - expected_mean).norm(), 1e-14 * expected_mean.norm());
    for (int a = 0; a < D; ++a) {
      for (int c = a; c < D; ++c) {
        EXPECT_NEAR(covariance(a, c), expected(a, c), 1e-13 * expected.norm()) << a << c;
        if (entries == Entries::kAll) {
          EXPECT_EQ(covariance(c, a), covariance(a, c));
        }
      }
    }
  }
}

// The bit pattern of a double, for exact comparison (NaN equal to itself).
std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v); }

template <class P>
double lane(const P& pack, int l) {
  double lanes[kLanesOf<P>];
  lane_store(lanes, pack);
  return lanes[l];
}

// Every function of the file over a pack P and over each of its lanes as a double, on inputs
// that differ per lane (some with underflowing and far-off values, one lane with every centered
// value −∞), compared to the bit.
template <class P, class Fn, Division kDivision>
void expect_lanes_equal_doubles(std::mt19937_64& rng) {
  constexpr int W = kLanesOf<P>, N = 5, D = 3;
  std::uniform_real_distribution<double> u(-30.0, 0.0);
  std::normal_distribution<double> g;
  const int n = N;
  const Eigen::MatrixXd p = random_transition(n, rng, 0.0);
  double log_mu[N][W], centered[N][W], m[N][D][W], cov[N][D][D][W], w[N][W];
  for (int i = 0; i < n; ++i) {
    for (int l = 0; l < W; ++l) {
      log_mu[i][l] = u(rng);
      centered[i][l] = l == 3 && i == 2 ? -1e30 : l == 5 ? -kInf : 40.0 * u(rng);
      w[i][l] = l == 1 && i == 0 ? 0.0 : -u(rng);
      for (int a = 0; a < D; ++a) {
        m[i][a][l] = 100.0 * g(rng);
        for (int c = 0; c < D; ++c) cov[i][a][c][l] = cov[i][c][a][l] = 1.0 + g(rng) * g(rng);
      }
    }
  }
  auto pack_of = [](const double(&v)[W]) { return lane_load<P>(v); };
  auto pt = [&p](int i, int j) { return p(i, j); };

  // The pack instance.
  std::array<P, N> plog_mu{}, pscaled{}, ppredicted{}, plog_c{}, pcentered{}, pposterior{},
      pnormalized{};
  std::array<P, std::size_t{N} * N> pweights{};
  for (int i = 0; i < n; ++i) {
    plog_mu[i] = pack_of(log_mu[i]);
    pcentered[i] = pack_of(centered[i]);
  }
  const P pshift = scaled_probabilities<Fn>(n, plog_mu, pscaled);
  predict_probabilities<Fn, kDivision>(n, pt, pscaled, pshift, ppredicted, plog_c, pweights.data());
  const P pmixture = log_sum_exp<Fn>(n, pcentered);
  P psum, plog_sum;
  const P ptop = posterior<Fn>(n, pcentered, pposterior, psum, plog_sum);
  normalized<Fn, P>(
      n, [&](int j) { return plog_mu[j]; }, pnormalized);
  P pmean[D], pcov[D][D];
  collapse<D, P>(
      n, [&](int i) { return pack_of(w[i]); }, [&](int i, int a) { return pack_of(m[i][a]); },
      [&](int i, int a, int c) { return pack_of(cov[i][a][c]); },
      [&](int a) -> P& { return pmean[a]; }, [&](int a, int c) -> P& { return pcov[a][c]; });

  // Each lane alone.
  for (int l = 0; l < W; ++l) {
    std::array<double, N> dlog_mu{}, dscaled{}, dpredicted{}, dlog_c{}, dcentered{}, dposterior{},
        dnormalized{};
    std::array<double, std::size_t{N} * N> dweights{};
    for (int i = 0; i < n; ++i) {
      dlog_mu[i] = log_mu[i][l];
      dcentered[i] = centered[i][l];
    }
    const double dshift = scaled_probabilities<Fn>(n, dlog_mu, dscaled);
    predict_probabilities<Fn, kDivision>(n, pt, dscaled, dshift, dpredicted, dlog_c,
                                         dweights.data());
    const double dmixture = log_sum_exp<Fn>(n, dcentered);
    double dsum = 0.0, dlog_sum = 0.0;
    const double dtop = posterior<Fn>(n, dcentered, dposterior, dsum, dlog_sum);
    normalized<Fn, double>(
        n, [&](int j) { return dlog_mu[j]; }, dnormalized);
    double dmean[D], dcov[D][D];
    collapse<D, double>(
        n, [&](int i) { return w[i][l]; }, [&](int i, int a) { return m[i][a][l]; },
        [&](int i, int a, int c) { return cov[i][a][c][l]; },
        [&](int a) -> double& { return dmean[a]; },
        [&](int a, int c) -> double& { return dcov[a][c]; });

    EXPECT_EQ(bits(dmixture), bits(lane(pmixture, l)));
    EXPECT_EQ(bits(dtop), bits(lane(ptop, l)));
    EXPECT_EQ(bits(dsum), bits(lane(psum, l)));
    EXPECT_EQ(bits(dlog_sum), bits(lane(plog_sum, l)));
    for (int j = 0; j < n; ++j) {
      EXPECT_EQ(bits(dscaled[j]), bits(lane(pscaled[j], l))) << "lane " << l;
      EXPECT_EQ(bits(dpredicted[j]), bits(lane(ppredicted[j], l)));
      EXPECT_EQ(bits(dlog_c[j]), bits(lane(plog_c[j], l)));
      EXPECT_EQ(bits(dcentered[j]), bits(lane(pcentered[j], l)));
      EXPECT_EQ(bits(dposterior[j]), bits(lane(pposterior[j], l)));
      EXPECT_EQ(bits(dnormalized[j]), bits(lane(pnormalized[j], l)));
      for (int i = 0; i < n; ++i)
        EXPECT_EQ(bits(dweights[j * n + i]), bits(lane(pweights[j * n + i], l)));
    }
    for (int a = 0; a < D; ++a) {
      EXPECT_EQ(bits(dmean[a]), bits(lane(pmean[a], l)));
      for (int c = a; c < D; ++c) EXPECT_EQ(bits(dcov[a][c]), bits(lane(pcov[a][c], l)));
    }
  }
}

TEST(ImmAlgebra, EveryLaneOfAPackIsTheDoubleInstanceToTheBit) {
  std::mt19937_64 rng(3);
  for (int round = 0; round < 20; ++round) {
    expect_lanes_equal_doubles<LanePackOf<8>, LaneFunctions, Division::kInverse>(rng);
    expect_lanes_equal_doubles<LanePackOf<4>, LaneFunctions, Division::kDivide>(rng);
    expect_lanes_equal_doubles<LanePackOf<8>, LibmFunctions, Division::kDivide>(rng);
    expect_lanes_equal_doubles<LanePackOf<2>, LibmFunctions, Division::kInverse>(rng);
  }
}

}  // namespace
}  // namespace imm::algebra
