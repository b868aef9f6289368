// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/uncertainty.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include "imm/datasets/random.hpp"

namespace imm::evaluation {

std::string Difference::text(int decimals) const {
  char buffer[96];
  // A difference too small for the decimals would read "+0.0000 [+0.0000, +0.0000]", which says
  // nothing: it is given to three significant digits instead.
  const double largest = std::max({std::abs(estimate), std::abs(lower), std::abs(upper)});
  const bool tiny = largest > 0.0 && largest < 0.5 * std::pow(10.0, -decimals);
  // An interval narrower than the decimals show would read "+0.0 [+0.0, +0.1]" beside a gate that
  // says +0.04: the decimals grow until the interval's width has two significant digits.
  const double width = upper - lower;
  if (!tiny && width > 0.0 && std::isfinite(width)) {
    const int needed = static_cast<int>(std::ceil(-std::log10(width))) + 1;
    decimals = std::clamp(std::max(decimals, needed), 0, 8);
  }
  if (tiny) {
    std::snprintf(buffer, sizeof buffer, "%+.3g [%+.3g, %+.3g]", estimate, lower, upper);
  } else {
    std::snprintf(buffer, sizeof buffer, "%+.*f [%+.*f, %+.*f]", decimals, estimate, decimals,
                  lower, decimals, upper);
  }
  return buffer;
}

Difference paired_difference(int runs, const Statistic& a, const Statistic& b, std::uint64_t seed,
                             int draws) {
  if (runs < 1) throw std::invalid_argument("paired_difference: no runs");
  Difference d;
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(runs);
  const double a_value = a(ones), b_value = b(ones);
  d.estimate = a_value - b_value;
  // Two filters that are the same filter computed two ways (a learned model with its learned part
  // switched off, and its baseline) differ by rounding, with the same sign on every resample: that
  // is no difference, and must not read as "beats".
  const double rounding = kRoundingLevel * std::max(std::abs(a_value), std::abs(b_value));
  const auto at_rounding_level = [&](const Difference& x) {
    return std::abs(x.estimate) <= rounding && std::abs(x.lower) <= rounding &&
           std::abs(x.upper) <= rounding;
  };
  if (runs < 2) {
    d.lower = d.upper = d.estimate;
    return d;
  }
  datasets::Rng rng(seed);
  std::vector<double> differences;
  differences.reserve(static_cast<std::size_t>(draws));
  Eigen::VectorXd weights(runs);
  for (int draw = 0; draw < draws; ++draw) {
    weights.setZero();
    for (int i = 0; i < runs; ++i) weights(static_cast<Eigen::Index>(rng.below(runs))) += 1.0;
    const double value = a(weights) - b(weights);
    if (std::isfinite(value)) differences.push_back(value);
  }
  if (differences.empty()) {
    d.lower = d.upper = d.estimate;
    return d;
  }
  std::sort(differences.begin(), differences.end());
  auto at = [&](double p) {
    const auto k =
        static_cast<std::size_t>(std::clamp(p * static_cast<double>(differences.size() - 1) + 0.5,
                                            0.0, static_cast<double>(differences.size() - 1)));
    return differences[k];
  };
  d.lower = at(0.025);
  d.upper = at(0.975);
  if (at_rounding_level(d)) d = Difference{};
  return d;
}

Statistic mean_of(const Eigen::VectorXd& per_run) {
  return [per_run](const Eigen::VectorXd& w) { return w.dot(per_run) / w.sum(); };
}

double standard_error(const Eigen::VectorXd& per_run) {
  const auto n = static_cast<double>(per_run.size());
  if (n < 2) return 0.0;
  const double mean = per_run.mean();
  return std::sqrt((per_run.array() - mean).square().sum() / (n - 1.0) / n);
}

std::string_view verdict(std::span<const Difference> differences) {
  bool better = false, worse = false;
  for (const Difference& d : differences) {
    better |= d.below();
    worse |= d.above();
  }
  if (better && worse) return "mixed";
  if (better) return "beats";
  if (worse) return "loses to";
  return "ties";
}

}  // namespace imm::evaluation
