// SPDX-License-Identifier: Apache-2.0
#include "imm/models/motion/singer.hpp"

#include <cmath>

namespace imm {
namespace {

// Below this αT the closed-form brackets lose more than ~4 digits to cancellation; their Taylor
// series (alternating, terms ≤ (2x)ⁿ/n!) converge to full precision in under 30 terms there.
constexpr double kSeriesThreshold = 0.5;
constexpr int kSeriesTerms = 30;

// Coefficients of xⁿ in e^{−x}, e^{−2x} and x·e^{−x}.
double exp1(int n, double factorial) { return ((n % 2 == 0) ? 1.0 : -1.0) / factorial; }
double exp2(int n, double factorial) { return std::pow(-2.0, n) / factorial; }
double x_exp1(int n, double factorial_n_minus_1) {
  return (((n - 1) % 2 == 0) ? 1.0 : -1.0) / factorial_n_minus_1;
}

// Σ_{n ≥ first} c(n) xⁿ, where c receives n, n! and (n−1)!. Orders below `first` cancel exactly
// in the closed form and are therefore skipped, not summed as rounding noise.
template <class Coefficient>
double series(double x, int first, Coefficient c) {
  double factorial_prev = 1.0;  // (n−1)!
  for (int n = 2; n < first; ++n) factorial_prev *= n;
  double factorial = factorial_prev * first;  // first!
  double sum = 0.0;
  double power = std::pow(x, first);
  for (int n = first; n < first + kSeriesTerms; ++n) {
    sum += c(n, factorial, factorial_prev) * power;
    power *= x;
    factorial_prev = factorial;
    factorial *= n + 1;
  }
  return sum;
}

// The six brackets B_ij(x) of Q_ij = B_ij / (2 αᵏ), x = αT.
struct Brackets {
  double b11, b12, b13, b22, b23, b33;
};

Brackets singer_brackets(double x) {
  Brackets b{};
  if (x < kSeriesThreshold) {
    b.b11 = series(x, 5,
                   [](int n, double f, double fm1) { return -exp2(n, f) - 4.0 * x_exp1(n, fm1); });
    b.b12 = series(x, 4, [](int n, double f, double fm1) {
      return exp2(n, f) - 2.0 * exp1(n, f) + 2.0 * x_exp1(n, fm1);
    });
    b.b13 = series(x, 3,
                   [](int n, double f, double fm1) { return -exp2(n, f) - 2.0 * x_exp1(n, fm1); });
    b.b22 = series(x, 3, [](int n, double f, double) { return 4.0 * exp1(n, f) - exp2(n, f); });
    b.b23 = series(x, 2, [](int n, double f, double) { return exp2(n, f) - 2.0 * exp1(n, f); });
    b.b33 = series(x, 1, [](int n, double f, double) { return -exp2(n, f); });
    return b;
  }
  const double e1 = std::exp(-x);
  const double e2 = std::exp(-2.0 * x);
  b.b11 = 1.0 - e2 + 2.0 * x + 2.0 / 3.0 * x * x * x - 2.0 * x * x - 4.0 * x * e1;
  b.b12 = e2 + 1.0 - 2.0 * e1 + 2.0 * x * e1 - 2.0 * x + x * x;
  b.b13 = 1.0 - e2 - 2.0 * x * e1;
  b.b22 = 4.0 * e1 - 3.0 - e2 + 2.0 * x;
  b.b23 = (1.0 - e1) * (1.0 - e1);
  b.b33 = 1.0 - e2;
  return b;
}

}  // namespace

SquareMatrix<3> singer_axis_transition(double T, double tau) {
  const double alpha = 1.0 / tau;
  const double x = alpha * T;
  // (x − 1 + e^{−x}) = Σ_{n≥2} (−x)ⁿ/n!, summed directly for small x.
  const double f13_bracket = x < kSeriesThreshold
                                 ? series(x, 2, [](int n, double f, double) { return exp1(n, f); })
                                 : x - 1.0 + std::exp(-x);
  SquareMatrix<3> F;
  F << 1.0, T, f13_bracket * tau * tau,  //
      0.0, 1.0, -std::expm1(-x) * tau,   //
      0.0, 0.0, std::exp(-x);
  return F;
}

SquareMatrix<3> singer_axis_noise(double T, double tau, double sigma_a) {
  const double alpha = 1.0 / tau;
  const double q = 2.0 * sigma_a * sigma_a / tau;  // PSD of the white noise driving ȧ
  const Brackets b = singer_brackets(alpha * T);
  const double t2 = tau * tau, t3 = t2 * tau, t4 = t3 * tau, t5 = t4 * tau;
  SquareMatrix<3> Q;
  Q(0, 0) = b.b11 * t5 / 2.0;
  Q(0, 1) = Q(1, 0) = b.b12 * t4 / 2.0;
  Q(0, 2) = Q(2, 0) = b.b13 * t3 / 2.0;
  Q(1, 1) = b.b22 * t3 / 2.0;
  Q(1, 2) = Q(2, 1) = b.b23 * t2 / 2.0;
  Q(2, 2) = b.b33 * tau / 2.0;
  return q * Q;
}

}  // namespace imm
