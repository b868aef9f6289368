// SPDX-License-Identifier: Apache-2.0
#include "imm/math/chi_square.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace imm {
namespace {

constexpr double kEpsilon = 1e-15;
constexpr int kMaxIterations = 100000;

// P(a, x) by its series, for x < a + 1: e^{−x} x^a / Γ(a + 1) Σ_n x^n / ((a + 1)…(a + n)).
double gamma_p_series(double a, double x) {
  double term = 1.0 / a;
  double sum = term;
  for (int n = 1; n < kMaxIterations; ++n) {
    term *= x / (a + n);
    sum += term;
    if (std::abs(term) < std::abs(sum) * kEpsilon) break;
  }
  return sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
}

// Q(a, x) = 1 − P(a, x) by its continued fraction (modified Lentz), for x ≥ a + 1.
double gamma_q_continued_fraction(double a, double x) {
  constexpr double kTiny = std::numeric_limits<double>::min() / kEpsilon;
  double b = x + 1.0 - a;
  double c = 1.0 / kTiny;
  double d = 1.0 / b;
  double h = d;
  for (int i = 1; i < kMaxIterations; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < kEpsilon) break;
  }
  return std::exp(-x + a * std::log(x) - std::lgamma(a)) * h;
}

}  // namespace

double regularized_gamma_p(double a, double x) {
  if (!(a > 0.0) || !std::isfinite(a) || !(x >= 0.0)) {
    throw std::invalid_argument("regularized_gamma_p: needs a > 0 and x ≥ 0");
  }
  if (x == 0.0) return 0.0;
  if (std::isinf(x)) return 1.0;
  return x < a + 1.0 ? gamma_p_series(a, x) : 1.0 - gamma_q_continued_fraction(a, x);
}

double chi_square_quantile(double p, double dof) {
  if (!(p > 0.0 && p < 1.0) || !(dof > 0.0) || !std::isfinite(dof)) {
    throw std::invalid_argument("chi_square_quantile: needs 0 < p < 1 and dof > 0");
  }
  const double a = dof / 2.0;
  const auto cdf = [a](double x) { return regularized_gamma_p(a, x / 2.0); };
  // A bracket [lo, hi] with cdf(lo) ≤ p ≤ cdf(hi), then bisection to the bracket's rounding: the
  // CDF is monotone, so this cannot fail; a Newton step from the bracket's middle speeds it up.
  double lo = 0.0, hi = std::max(1.0, dof);
  while (cdf(hi) < p) {
    lo = hi;
    hi *= 2.0;
  }
  for (int i = 0; i < 2000 && hi - lo > 1e-14 * hi; ++i) {
    double x = 0.5 * (lo + hi);
    const double f = cdf(x) - p;
    (f < 0.0 ? lo : hi) = x;
    // Newton from the midpoint, kept only when it lands inside the new bracket.
    const double density = std::exp((a - 1.0) * std::log(x / 2.0) - x / 2.0 - std::lgamma(a)) / 2.0;
    if (density > 0.0) {
      const double newton = x - f / density;
      if (newton > lo && newton < hi) {
        x = newton;
        (cdf(x) - p < 0.0 ? lo : hi) = x;
      }
    }
  }
  return 0.5 * (lo + hi);
}

}  // namespace imm
