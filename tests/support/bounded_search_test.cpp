// SPDX-License-Identifier: Apache-2.0
#include "imm/support/bounded_search.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace imm::support {
namespace {

// A separable quadratic with its minimum at `center`.
SearchObjective bowl(std::vector<double> center) {
  return [center](const std::vector<double>& x) {
    double sum = 0.0;
    for (std::size_t d = 0; d < x.size(); ++d) sum += (x[d] - center[d]) * (x[d] - center[d]);
    return sum;
  };
}

TEST(Subplex, StartingOnABoundStillSearches) {
  // NLopt's default first step is the room left before the nearer bound: ~1e-16 for a start one
  // rounding error inside a bound (a value fitted earlier against the same bound), which made
  // Subplex stop "converged" after one evaluation. The minimum is in the box's interior.
  const std::vector<double> lower = {-3.0, 0.0, 0.0}, upper = {5.0, 8.0, 1.0};
  const double just_inside = std::nextafter(-3.0, 0.0);
  const SearchResult result =
      subplex(bowl({1.0, 2.5, 0.3}), {just_inside, 0.0, 1.0}, lower, upper, 400, 1e-6);
  EXPECT_GT(result.evaluations, 10);
  EXPECT_NEAR(result.x[0], 1.0, 1e-3);
  EXPECT_NEAR(result.x[1], 2.5, 1e-3);
  EXPECT_NEAR(result.x[2], 0.3, 1e-3);
}

TEST(Subplex, StaysInsideTheBox) {
  const std::vector<double> lower = {0.0, 0.0}, upper = {1.0, 1.0};
  const SearchResult result = subplex(bowl({3.0, -2.0}), {0.5, 0.5}, lower, upper, 300, 1e-8);
  EXPECT_NEAR(result.x[0], 1.0, 1e-6);
  EXPECT_NEAR(result.x[1], 0.0, 1e-6);
  EXPECT_NEAR(result.value, 4.0 + 4.0, 1e-5);
}

TEST(GridThenSubplex, NonFiniteValuesCountAsWorst) {
  const auto f = [](const std::vector<double>& x) {
    return x[0] < 0.2 ? std::nan("") : (x[0] - 0.6) * (x[0] - 0.6);
  };
  const SearchResult result = grid_then_subplex(
      f, {0.0}, {1.0}, {.grid_points = 6, .polish_evaluations = 60, .xtol_abs = 1e-8});
  EXPECT_TRUE(std::isfinite(result.value));
  EXPECT_NEAR(result.x[0], 0.6, 1e-4);
}

}  // namespace
}  // namespace imm::support
