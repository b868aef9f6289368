// SPDX-License-Identifier: Apache-2.0
// The linear assignment solver and GOSPA (imm/evaluation/assignment.hpp, gospa.hpp) against brute
// force: every injective matching of small random matrices (square, wide, tall, with forbidden
// pairs), every partial matching for the gated form and for GOSPA's definition; and the closed
// forms of GOSPA's parts.

#include "imm/evaluation/assignment.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>

#include "imm/core/invalid_parameter.hpp"
#include "imm/evaluation/gospa.hpp"
#include "testing/refused_field.hpp"

namespace imm::evaluation {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The least total over every matching of min(rows, cols) pairs (+∞ when none avoids +∞), by
// enumeration; `partial`: over every matching of any size, each row or column left out costing
// `unassigned`.
double brute_force(const Eigen::MatrixXd& c, bool partial = false, double unassigned = 0.0) {
  const auto n = static_cast<int>(c.rows()), m = static_cast<int>(c.cols());
  std::vector<char> used(static_cast<std::size_t>(m), 0);
  double best = kInf;
  std::function<void(int, double, int)> visit = [&](int i, double total, int pairs) {
    if (i == n) {
      if (partial) {
        best = std::min(best, total + unassigned * (n + m - 2 * pairs));
      } else if (pairs == std::min(n, m)) {
        best = std::min(best, total);
      }
      return;
    }
    if (partial || n > m) visit(i + 1, total, pairs);  // row i left out
    for (int j = 0; j < m; ++j) {
      if (used[static_cast<std::size_t>(j)] || c(i, j) == kInf) continue;
      used[static_cast<std::size_t>(j)] = 1;
      visit(i + 1, total + c(i, j), pairs + 1);
      used[static_cast<std::size_t>(j)] = 0;
    }
  };
  visit(0, 0.0, 0);
  return best;
}

double total_of(const Eigen::MatrixXd& c, const std::vector<int>& column_of) {
  double total = 0.0;
  std::vector<int> seen;
  for (std::size_t i = 0; i < column_of.size(); ++i) {
    const int j = column_of[i];
    if (j < 0) continue;
    EXPECT_EQ(std::count(seen.begin(), seen.end(), j), 0) << "column " << j << " twice";
    seen.push_back(j);
    total += c(static_cast<Eigen::Index>(i), j);
  }
  return total;
}

TEST(Assignment, TheSciPyDocumentationsExample) {
  Eigen::MatrixXd c(3, 3);
  c << 4, 1, 3, 2, 0, 5, 3, 2, 2;
  EXPECT_EQ(min_cost_assignment(c), (std::vector<int>{1, 0, 2}));
}

TEST(Assignment, EqualsBruteForceOnRandomMatricesWithForbiddenPairs) {
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> value(0.0, 10.0), chance(0.0, 1.0);
  int feasible = 0, infeasible = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const int n = 1 + trial % 6, m = 1 + (trial / 6) % 6;
    Eigen::MatrixXd c(n, m);
    for (Eigen::Index k = 0; k < c.size(); ++k) {
      c.data()[k] = chance(rng) < 0.25 ? kInf : std::round(value(rng) * 4.0) / 4.0;  // ties too
    }
    const double expected = brute_force(c);
    if (expected == kInf) {
      EXPECT_THROW((void)min_cost_assignment(c), InvalidParameter) << c;
      ++infeasible;
      continue;
    }
    const std::vector<int> chosen = min_cost_assignment(c);
    ASSERT_EQ(chosen.size(), static_cast<std::size_t>(n));
    EXPECT_EQ(std::count_if(chosen.begin(), chosen.end(), [](int j) { return j >= 0; }),
              std::min(n, m));
    EXPECT_NEAR(total_of(c, chosen), expected, 1e-9) << c;
    ++feasible;
  }
  EXPECT_GT(feasible, 200);
  EXPECT_GE(infeasible, 5);
}

TEST(Assignment, GatedEqualsTheBestPartialMatching) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> value(0.0, 10.0), chance(0.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const int n = trial % 5, m = (trial / 5) % 6;  // empty sides too
    Eigen::MatrixXd c(n, m);
    for (Eigen::Index k = 0; k < c.size(); ++k) c.data()[k] = chance(rng) < 0.3 ? kInf : value(rng);
    const double unassigned = 3.0;
    const std::vector<int> chosen = gated_assignment(c, unassigned);
    ASSERT_EQ(chosen.size(), static_cast<std::size_t>(n));
    const int pairs =
        static_cast<int>(std::count_if(chosen.begin(), chosen.end(), [](int j) { return j >= 0; }));
    const double total = total_of(c, chosen) + unassigned * (n + m - 2 * pairs);
    EXPECT_NEAR(total, brute_force(c, true, unassigned), 1e-9) << c;
    for (std::size_t i = 0; i < chosen.size(); ++i) {
      if (chosen[i] >= 0) {
        EXPECT_LT(c(static_cast<Eigen::Index>(i), chosen[i]), kInf);
      }
    }
  }
}

TEST(Assignment, RefusesNaNAndMinusInfinityAndABadUnassignedCost) {
  Eigen::MatrixXd c = Eigen::MatrixXd::Ones(2, 2);
  c(0, 1) = std::nan("");
  EXPECT_THROW((void)min_cost_assignment(c), InvalidParameter);
  c(0, 1) = -kInf;
  EXPECT_THROW((void)min_cost_assignment(c), InvalidParameter);
  try {
    (void)gated_assignment(Eigen::MatrixXd::Ones(2, 2), -1.0);
    ADD_FAILURE();
  } catch (const InvalidParameter& error) {
    EXPECT_EQ(error.field(), "unassigned");
  }
}

Eigen::Matrix2Xd points(std::initializer_list<std::pair<double, double>> list) {
  Eigen::Matrix2Xd out(2, static_cast<Eigen::Index>(list.size()));
  Eigen::Index k = 0;
  for (const auto& [x, y] : list) out.col(k++) << x, y;
  return out;
}

TEST(Gospa, ItsClosedForms) {
  const double c = 10.0;
  EXPECT_EQ(gospa(points({}), points({}), c).distance, 0.0);
  const Gospa missed = gospa(points({{0, 0}}), points({}), c);
  EXPECT_DOUBLE_EQ(missed.distance, std::sqrt(50.0));  // (c²/2)^(1/2)
  EXPECT_EQ(missed.missed_targets, 1);
  const Gospa false_one = gospa(points({}), points({{1, 1}}), c);
  EXPECT_DOUBLE_EQ(false_one.false_tracks, 50.0);
  const Gospa near = gospa(points({{0, 0}}), points({{3, 4}}), c);
  EXPECT_DOUBLE_EQ(near.distance, 5.0);
  EXPECT_DOUBLE_EQ(near.localization, 25.0);
  EXPECT_EQ(near.estimate_of, (std::vector<int>{0}));
  const Gospa far = gospa(points({{0, 0}}), points({{30, 40}}), c);  // beyond c: missed + false
  EXPECT_DOUBLE_EQ(far.distance, 10.0);
  EXPECT_EQ(far.assigned, 0);
  EXPECT_EQ(far.missed_targets + far.false_estimates, 2);
  EXPECT_EQ(far.estimate_of, (std::vector<int>{-1}));
  const Gospa same = gospa(points({{1, 2}, {5, 5}}), points({{5, 5}, {1, 2}}), c);
  EXPECT_EQ(same.distance, 0.0);
  EXPECT_EQ(same.estimate_of, (std::vector<int>{1, 0}));
  EXPECT_DOUBLE_EQ(gospa(points({{0, 0}}), points({{0, 3}}), c, 1.0).distance, 3.0);
}

TEST(Gospa, EqualsItsDefinitionByBruteForce) {
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> coordinate(0.0, 30.0);
  const double c = 8.0, p = 2.0;
  for (int trial = 0; trial < 150; ++trial) {
    const int n = trial % 5, m = (trial / 5) % 5;
    Eigen::Matrix2Xd x(2, n), y(2, m);
    for (Eigen::Index k = 0; k < x.size(); ++k) x.data()[k] = coordinate(rng);
    for (Eigen::Index k = 0; k < y.size(); ++k) y.data()[k] = coordinate(rng);
    // The definition: pairs only below c, each unpaired point c^p/2.
    Eigen::MatrixXd d(n, m);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < m; ++j) {
        const double distance = (x.col(i) - y.col(j)).norm();
        d(i, j) = distance < c ? std::pow(distance, p) : kInf;
      }
    }
    const double expected = std::pow(brute_force(d, true, 0.5 * std::pow(c, p)), 1.0 / p);
    const Gospa g = gospa(x, y, c, p);
    EXPECT_NEAR(g.distance, expected, 1e-9);
    EXPECT_NEAR(std::pow(g.distance, p), g.localization + g.missed + g.false_tracks, 1e-9);
  }
}

TEST(Gospa, RefusesABadCutoffOrderOrPosition) {
  EXPECT_EQ(testing::refused_field_of([] { (void)gospa(points({}), points({}), 0.0); }), "cutoff");
  EXPECT_EQ(testing::refused_field_of([] { (void)gospa(points({}), points({}), 1.0, 0.5); }),
            "order");
  EXPECT_EQ(testing::refused_field_of([] {
              (void)gospa(points({{std::nan(""), 0}}), points({}), 1.0);
            }),
            "targets");
}

}  // namespace
}  // namespace imm::evaluation
