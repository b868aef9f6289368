// SPDX-License-Identifier: Apache-2.0
// Fuzzy c-means (seed 003's clustering): hand-computed memberships, the integer fuzzifiers
// against the general formula, known clusters recovered, bounded centers, the partial sums, and
// the sliding window against a batch run on it.

#include "imm/models/learned/fuzzy_c_means.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/random.hpp"

namespace imm {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
const ClusterVector unbounded = ClusterVector::Constant(kInf);

// --- Fuzzy c-means --------------------------------------------------------------------------

TEST(FuzzyCMeans, HandComputedMemberships) {
  // x = 1, centers (−1, 0, 3): d² = 4, 1, 4. m = 2: u ∝ 1/d² = (1/4, 1, 1/4) → (1/6, 2/3, 1/6);
  // m = 3: u ∝ (1/d²)^{1/2} = (1/2, 1, 1/2) → (1/4, 1/2, 1/4).
  const ClusterVector centers(-1.0, 0.0, 3.0);
  const ClusterVector m2 = fcm_memberships(1.0, centers, 2.0);
  EXPECT_NEAR(m2(0), 1.0 / 6.0, 1e-15);
  EXPECT_NEAR(m2(1), 2.0 / 3.0, 1e-15);
  EXPECT_NEAR(m2(2), 1.0 / 6.0, 1e-15);
  const ClusterVector m3 = fcm_memberships(1.0, centers, 3.0);
  EXPECT_NEAR(m3(0), 0.25, 1e-15);
  EXPECT_NEAR(m3(1), 0.5, 1e-15);
  EXPECT_NEAR(m3(2), 0.25, 1e-15);
}

// The integer fuzzifiers take roots and products instead of the general pow: the same
// memberships (eq. 9, u_i = 1 / Σ_j (d_i²/d_j²)^{1/(m−1)}, written here with pow) to rounding, and
// the general path for a fractional m; and the same objective weights u^m.
TEST(FuzzyCMeans, IntegerFuzzifiersAgreeWithTheGeneralFormula) {
  const ClusterVector centers(-2.0, 0.3, 4.5);
  for (const double m : {2.0, 2.5, 3.0, 4.0, 5.0, 3.7}) {
    for (const double x : {-7.0, -1.1, 0.0, 0.2999, 1.7, 9.0}) {
      const ClusterVector u = fcm_memberships(x, centers, m);
      for (int i = 0; i < kFcmClusters; ++i) {
        double sum = 0.0;
        for (int j = 0; j < kFcmClusters; ++j) {
          const double di = (x - centers(i)) * (x - centers(i));
          const double dj = (x - centers(j)) * (x - centers(j));
          sum += std::pow(di / dj, 1.0 / (m - 1.0));
        }
        EXPECT_NEAR(u(i), 1.0 / sum, 1e-14) << "m " << m << ", x " << x << ", cluster " << i;
      }
      const std::vector<double> data = {x};
      const std::vector<double> memberships(u.data(), u.data() + kFcmClusters);
      double objective = 0.0;
      for (int i = 0; i < kFcmClusters; ++i) {
        objective += std::pow(u(i), m) * (x - centers(i)) * (x - centers(i));
      }
      EXPECT_NEAR(fcm_objective(data, centers, memberships, m), objective, 1e-13 * objective)
          << "m " << m << ", x " << x;
    }
  }
}

// m = 4 takes its own cube root (fuzzy_c_means.cpp): over ratios from 1 down to 1e-30 and below,
// the memberships agree with libm's cube root to rounding (a few units in the last place).
TEST(FuzzyCMeans, TheFuzzifierFourCubeRootIsLibmsToRounding) {
  const ClusterVector centers(-1.0, 0.0, 1.0);
  for (int i = 0; i <= 4000; ++i) {
    const double x = std::pow(10.0, -15.0 + 30.0 * i / 4000.0) * (i % 2 == 0 ? 1.0 : -1.0);
    const ClusterVector u = fcm_memberships(x, centers, 4.0);
    double d2[kFcmClusters], smallest = std::numeric_limits<double>::infinity();
    for (int c = 0; c < kFcmClusters; ++c) {
      d2[c] = (x - centers(c)) * (x - centers(c));
      smallest = std::min(smallest, d2[c]);
    }
    if (smallest == 0.0) continue;  // on a center: PointOnACenterBelongsToItAlone
    double w[kFcmClusters], sum = 0.0;
    for (int c = 0; c < kFcmClusters; ++c) sum += w[c] = std::cbrt(smallest / d2[c]);
    for (int c = 0; c < kFcmClusters; ++c) {
      EXPECT_NEAR(u(c), w[c] / sum, 1e-15) << "x " << x << ", cluster " << c;
    }
  }
}

// The clustering updates the memberships of all points at once for m = 2 and 4 (a loop the
// compiler vectorizes, by blocks of 64): each row is fcm_memberships' for the centers to the bit —
// over 150 points (blocks and a remainder) with points on a center, one at a ratio of 1e-41 from
// one (below the cube root's guess, redone point by point), and coinciding values.
TEST(FuzzyCMeans, TheBatchUpdateIsThePointwiseRuleToTheBit) {
  datasets::Rng rng(17);
  std::vector<double> data(150);
  for (double& x : data) x = rng.normal(0.0, 3.0);
  // Centers pinned by their bounds, so that points can sit on them (and next to them).
  const ClusterVector centers(-3.0, 0.0, 3.0);
  data[3] = -3.0;
  data[70] = 0.0;
  data[71] = 1e-20;  // a ratio of 1e-40/9 from the center at 0
  data[140] = data[141];
  for (const double m : {2.0, 4.0}) {
    FuzzyCMeansSettings settings;
    settings.fuzzifier = m;
    settings.max_iterations = 1;
    std::vector<double> memberships(3 * data.size());
    const FcmResult result = fuzzy_c_means(data, centers, centers, centers, settings, memberships);
    const std::vector<double>& special = data;
    ASSERT_EQ(result.iterations, 1);
    for (std::size_t k = 0; k < special.size(); ++k) {
      const ClusterVector expected = fcm_memberships(special[k], result.centers, m);
      for (int i = 0; i < kFcmClusters; ++i) {
        EXPECT_EQ(memberships[3 * k + static_cast<std::size_t>(i)], expected(i))
            << "m " << m << ", point " << k << ", cluster " << i;
      }
    }
  }
}

TEST(FuzzyCMeans, PointOnACenterBelongsToItAlone) {
  const ClusterVector centers(-2.0, 0.5, 4.0);
  for (double m : {1.5, 2.0, 3.7}) {
    const ClusterVector u = fcm_memberships(0.5, centers, m);
    EXPECT_EQ(u, ClusterVector(0.0, 1.0, 0.0));
  }
  // Two coinciding centers share the point.
  EXPECT_EQ(fcm_memberships(1.0, ClusterVector(1.0, 1.0, 5.0), 2.0), ClusterVector(0.5, 0.5, 0.0));
  // Far-out and near points stay finite: no overflow of the ratio form.
  const ClusterVector tiny = fcm_memberships(1e-300, ClusterVector(-1.0, 0.0, 1.0), 1.1);
  EXPECT_TRUE(tiny.allFinite());
  EXPECT_NEAR(tiny(1), 1.0, 1e-12);
}

TEST(FuzzyCMeans, MembershipsAreScaleFree) {
  const ClusterVector centers(-3.0, 0.2, 2.5);
  for (double x : {-4.0, -1.0, 0.0, 0.7, 9.0}) {
    const ClusterVector u = fcm_memberships(x, centers, 2.3);
    const ClusterVector scaled = fcm_memberships(1000.0 * x, 1000.0 * centers, 2.3);
    EXPECT_NEAR((u - scaled).cwiseAbs().maxCoeff(), 0.0, 1e-13);
  }
}

TEST(FuzzyCMeans, RecoversThreeWellSeparatedClusters) {
  datasets::Rng rng(11);
  std::vector<double> data;
  const double truth[3] = {-10.0, 0.0, 12.0};
  for (int k = 0; k < 60; ++k) {
    for (double center : truth) data.push_back(rng.normal(center, 0.5));
  }
  std::vector<double> u(3 * data.size());
  FuzzyCMeansSettings settings;
  settings.tolerance = 1e-9;
  const FcmResult result =
      fuzzy_c_means(data, ClusterVector(-1.0, 0.0, 1.0), -unbounded, unbounded, settings, u);
  EXPECT_TRUE(result.converged);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(result.centers(i), truth[i], 0.2) << i;
  for (std::size_t k = 0; k < data.size(); ++k) {
    EXPECT_NEAR(u[3 * k] + u[3 * k + 1] + u[3 * k + 2], 1.0, 1e-14);
    // Every point belongs mostly to its own cluster.
    const std::size_t own = k % 3;
    EXPECT_GT(u[3 * k + own], 0.9) << k;
  }
}

TEST(FuzzyCMeans, BoundedCentersStayInTheirBounds) {
  // Data around +1 only: the acceleration center wants to sit at ≈ 1, but must stay ≥ 3; the noise
  // center is pinned at 0.
  std::vector<double> data = {0.8, 1.0, 1.2, 0.9, 1.1, -0.1, 0.1};
  std::vector<double> u(3 * data.size());
  const FcmResult result =
      fuzzy_c_means(data, ClusterVector(-5.0, 0.0, 5.0), ClusterVector(-kInf, 0.0, 3.0),
                    ClusterVector(-3.0, 0.0, kInf), FuzzyCMeansSettings{}, u);
  EXPECT_EQ(result.centers(1), 0.0);
  EXPECT_LE(result.centers(0), -3.0);
  EXPECT_EQ(result.centers(2), 3.0);  // clamped: the unconstrained optimum lies inside the bound
}

// A data set's centers (fuzzy_c_means_from_memberships) are eq. (8) with its sums over the points
// taken in eight partial sums, point k into sum k mod 8, added pairwise at the end: written out
// here for sizes around multiples of eight and for the fuzzifiers with products and with pow, to
// the bit; and within rounding of the sums in long double.
TEST(FuzzyCMeans, ADataSetsCentersAreItsSumsInEightPartialSums) {
  datasets::Rng rng(23);
  for (const std::size_t n : {3U, 7U, 8U, 9U, 16U, 21U, 64U, 101U}) {
    for (const double m : {2.0, 2.5, 3.0, 4.0}) {
      std::vector<double> data(n), u(3 * n);
      for (double& x : data) x = rng.normal(0.0, 5.0);
      for (std::size_t k = 0; k < n; ++k) {
        const double a = rng.uniform(0.05, 1.0), b = rng.uniform(0.05, 1.0);
        const double c = rng.uniform(0.05, 1.0);
        u[3 * k] = a / (a + b + c);
        u[3 * k + 1] = b / (a + b + c);
        u[3 * k + 2] = c / (a + b + c);
      }
      ClusterVector expected, accurate;
      for (int i = 0; i < 3; ++i) {
        double numerator[8] = {}, denominator[8] = {};
        long double exact_numerator = 0.0L, exact_denominator = 0.0L;
        for (std::size_t k = 0; k < n; ++k) {
          const double w = std::pow(u[3 * k + static_cast<std::size_t>(i)], m);
          numerator[k % 8] += w * data[k];
          denominator[k % 8] += w;
          exact_numerator += static_cast<long double>(w) * data[k];
          exact_denominator += w;
        }
        const auto pairwise = [](const double(&s)[8]) {
          return ((s[0] + s[1]) + (s[2] + s[3])) + ((s[4] + s[5]) + (s[6] + s[7]));
        };
        expected(i) = pairwise(numerator) / pairwise(denominator);
        accurate(i) = static_cast<double>(exact_numerator / exact_denominator);
      }
      FuzzyCMeansSettings settings;
      settings.fuzzifier = m;
      settings.max_iterations = 1;
      const FcmResult result = fuzzy_c_means_from_memberships(data, u, settings);
      for (int i = 0; i < 3; ++i) {
        // pow(u, m) and weight_power's products agree for m = 2 (one rounding each); for 3 and 4
        // the products round twice, so those compare within rounding.
        if (m == 2.0 || m == 2.5) {
          EXPECT_EQ(result.centers(i), expected(i)) << "n " << n << ", m " << m << ", " << i;
        } else {
          EXPECT_NEAR(result.centers(i), expected(i), 1e-13 * (1.0 + std::abs(expected(i))));
        }
        EXPECT_NEAR(result.centers(i), accurate(i), 1e-13 * (1.0 + std::abs(accurate(i))))
            << "n " << n << ", m " << m << ", " << i;
      }
    }
  }
}
TEST(SlidingFuzzyCMeans, ProposeCommitAndTheWindow) {
  SlidingFuzzyCMeans fcm(5, FuzzyCMeansSettings{}, -unbounded, unbounded);
  // Fewer than three points: noise.
  EXPECT_EQ(fcm.propose(4.0), ClusterVector(0.0, 1.0, 0.0));
  fcm.commit();
  EXPECT_EQ(fcm.propose(-4.0), ClusterVector(0.0, 1.0, 0.0));
  fcm.commit();
  EXPECT_EQ(fcm.size(), 2);
  // Proposing does not change anything: the same proposal twice gives the same answer.
  const ClusterVector first = fcm.propose(0.1);
  const ClusterVector again = fcm.propose(0.1);
  EXPECT_EQ(first, again);
  EXPECT_EQ(fcm.size(), 2);
  fcm.commit();
  EXPECT_EQ(fcm.size(), 3);
  EXPECT_LT(fcm.centers()(0), fcm.centers()(1));
  EXPECT_LT(fcm.centers()(1), fcm.centers()(2));
  for (int k = 0; k < 10; ++k) {
    (void)fcm.propose(std::sin(k));
    fcm.commit();
  }
  EXPECT_EQ(fcm.size(), 5);
}

TEST(SlidingFuzzyCMeans, WarmStartAgreesWithABatchRunOnTheWindow) {
  const int window = 12;
  FuzzyCMeansSettings settings;
  settings.tolerance = 1e-10;
  settings.max_iterations = 10000;
  SlidingFuzzyCMeans online(window, settings, -unbounded, unbounded);
  datasets::Rng rng(5);
  std::vector<double> history;
  ClusterVector last;
  for (int k = 0; k < 40; ++k) {
    const double x = rng.normal(k % 7 == 0 ? 6.0 : 0.0, 1.0);
    history.push_back(x);
    last = online.propose(x);
    online.commit();
  }
  const std::vector<double> tail(history.end() - window, history.end());
  std::vector<double> u(3 * tail.size());
  const double lowest = *std::min_element(tail.begin(), tail.end());
  const double highest = *std::max_element(tail.begin(), tail.end());
  double mean = 0.0;
  for (double x : tail) mean += x / window;
  FcmResult batch =
      fuzzy_c_means(tail, ClusterVector(lowest, mean, highest), -unbounded, unbounded, settings, u);
  std::sort(batch.centers.data(), batch.centers.data() + 3);
  EXPECT_NEAR((batch.centers - online.centers()).cwiseAbs().maxCoeff(), 0.0, 1e-6);
  EXPECT_NEAR((fcm_memberships(history.back(), batch.centers, 2.0) - last).cwiseAbs().maxCoeff(),
              0.0, 1e-6);
}

TEST(SlidingFuzzyCMeans, RejectsBadSettings) {
  EXPECT_THROW(SlidingFuzzyCMeans(2, FuzzyCMeansSettings{}, -unbounded, unbounded),
               InvalidParameter);
  FuzzyCMeansSettings bad;
  bad.fuzzifier = 1.0;
  EXPECT_THROW(SlidingFuzzyCMeans(8, bad, -unbounded, unbounded), InvalidParameter);
  EXPECT_THROW(SlidingFuzzyCMeans(8, FuzzyCMeansSettings{}, ClusterVector(0.0, 1.0, 2.0),
                                  ClusterVector(0.0, 0.0, 2.0)),
               InvalidParameter);
}

// --- The update with a given gain -------------------------------------------------------------

}  // namespace
}  // namespace imm
