// SPDX-License-Identifier: Apache-2.0
#include "imm/support/bounded_search.hpp"

#include <cmath>
#include <nlopt.hpp>
#include <stdexcept>

namespace imm::support {
namespace {

double finite_or_max(double value) {
  return std::isfinite(value) ? value : std::numeric_limits<double>::max();
}

struct Context {
  const SearchObjective* f = nullptr;
  int evaluations = 0;
  SearchResult* best = nullptr;
};

double call(const std::vector<double>& x, std::vector<double>& /*gradient*/, void* data) {
  auto& c = *static_cast<Context*>(data);
  ++c.evaluations;
  const double value = finite_or_max((*c.f)(x));
  if (value < c.best->value) c.best->value = value, c.best->x = x;
  return value;
}

// Runs Subplex from `x`, recording the best point seen in `best`.
void polish(const SearchObjective& f, std::vector<double> x, const std::vector<double>& lower,
            const std::vector<double>& upper, int evaluations, double xtol_abs, double xtol_rel,
            SearchResult& best) {
  if (evaluations <= 0) return;
  Context context{&f, 0, &best};
  nlopt::opt optimizer(nlopt::LN_SBPLX, static_cast<unsigned>(x.size()));
  optimizer.set_lower_bounds(lower);
  optimizer.set_upper_bounds(upper);
  optimizer.set_maxeval(evaluations);
  if (xtol_abs > 0.0) optimizer.set_xtol_abs(xtol_abs);
  if (xtol_rel > 0.0) optimizer.set_xtol_rel(xtol_rel);
  optimizer.set_min_objective(call, &context);
  // NLopt's default first step shrinks to the room left before the nearer bound; at a bound it
  // becomes ~1e-16 and Subplex stops at once "converged" (xtol). Such a coordinate steps a
  // quarter of its range instead.
  std::vector<double> step(x.size());
  optimizer.get_initial_step(x, step);
  for (std::size_t d = 0; d < x.size(); ++d) {
    const double range = upper[d] - lower[d];
    if (range > 0.0 && std::abs(step[d]) < 1e-9 * range) step[d] = 0.25 * range;
  }
  optimizer.set_initial_step(step);
  double value = 0.0;
  try {
    (void)optimizer.optimize(x, value);
  } catch (const std::exception&) {
    // Subplex may stop on a roundoff-limited step: the best point seen is kept either way.
  }
  best.evaluations += context.evaluations;
}

void check_box(const std::vector<double>& lower, const std::vector<double>& upper) {
  if (lower.empty() || lower.size() != upper.size()) {
    throw std::invalid_argument("bounded search: lower and upper bounds differ in size");
  }
  for (std::size_t d = 0; d < lower.size(); ++d) {
    if (!(lower[d] <= upper[d])) throw std::invalid_argument("bounded search: lower > upper");
  }
}

}  // namespace

SearchResult grid_then_subplex(const SearchObjective& f, const std::vector<double>& lower,
                               const std::vector<double>& upper, const SearchOptions& options) {
  check_box(lower, upper);
  const std::size_t n = lower.size();
  const int points = std::max(1, options.grid_points);
  SearchResult best;
  std::vector<int> index(n, 0);
  while (true) {
    std::vector<double> x(n);
    bool keep = true;
    for (std::size_t d = 0; d < n; ++d) {
      x[d] = points == 1 ? lower[d] : lower[d] + (upper[d] - lower[d]) * index[d] / (points - 1);
      if (options.ordered && d > 0 && index[d] < index[d - 1]) keep = false;
    }
    if (keep) {
      const double value = finite_or_max(f(x));
      ++best.evaluations;
      if (value < best.value) best.value = value, best.x = x;
    }
    std::size_t d = 0;
    while (d < n && ++index[d] == points) index[d++] = 0;
    if (d == n) break;
  }
  polish(f, best.x, lower, upper, options.polish_evaluations, options.xtol_abs, options.xtol_rel,
         best);
  return best;
}

SearchResult subplex(const SearchObjective& f, const std::vector<double>& x0,
                     const std::vector<double>& lower, const std::vector<double>& upper,
                     int max_evaluations, double xtol_rel) {
  check_box(lower, upper);
  SearchResult best;
  best.x = x0;
  best.value = finite_or_max(f(x0));
  best.evaluations = 1;
  polish(f, x0, lower, upper, max_evaluations, 0.0, xtol_rel, best);
  return best;
}

}  // namespace imm::support
