// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Bounded derivative-free minimization for the tuners: a full grid over the box, then NLopt's
/// Subplex from the grid's best point. Tuning objectives here are Monte Carlo tracking scores —
/// noisy, piecewise smooth, with several local minima — so the grid finds the basin and Subplex
/// polishes it. Deterministic: the same objective gives the same evaluations in the same order.

#include <functional>
#include <limits>
#include <vector>

namespace imm::support {

using SearchObjective = std::function<double(const std::vector<double>&)>;

struct SearchOptions {
  int grid_points = 6;          ///< per dimension (≥ 2; 1: only the box's lower corner)
  int polish_evaluations = 60;  ///< Subplex's budget after the grid (0: no polish)
  bool ordered = false;   ///< grid: only points with x₀ ≤ x₁ ≤ … (ascending noise levels)
  double xtol_abs = 0.0;  ///< Subplex stops when steps fall below (0: unused)
  double xtol_rel = 0.0;  ///< … or below this relative size (0: unused)
};

struct SearchResult {
  std::vector<double> x;
  double value = std::numeric_limits<double>::infinity();
  int evaluations = 0;
};

/// Minimizes f over [lower, upper]. Non-finite objective values count as +∞.
[[nodiscard]] SearchResult grid_then_subplex(const SearchObjective& f,
                                             const std::vector<double>& lower,
                                             const std::vector<double>& upper,
                                             const SearchOptions& options);

/// Subplex alone from x0 within [lower, upper].
[[nodiscard]] SearchResult subplex(const SearchObjective& f, const std::vector<double>& x0,
                                   const std::vector<double>& lower,
                                   const std::vector<double>& upper, int max_evaluations,
                                   double xtol_rel = 1e-4);

}  // namespace imm::support
