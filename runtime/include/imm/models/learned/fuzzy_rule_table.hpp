// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// A fuzzy rule table mapping (residual, residual change) to a process-noise variance
/// (seed 000 §3.1–3.2):
///   rule l: if r is A₁ˡ and Δr is A₂ˡ then q is wˡ                                  (13)
///   μᵢˡ(xᵢ) = exp(−½ ((xᵢ − cᵢˡ)/σᵢˡ)²)                                               (14)
///   q(r, Δr) = Σₗ wˡ μ₁ˡ(r) μ₂ˡ(Δr) / Σₗ μ₁ˡ(r) μ₂ˡ(Δr)                              (19-5)
/// Units: r and Δr in measurement units (km in seed 000), w in (unit/s²)².
///
/// Far from every rule all firing strengths underflow and (19-5) is 0/0. Then — and whenever the
/// total firing strength is below the smallest normal double, where the quotient has lost its
/// precision — the table answers its mean w (SPEC §4.1).
///
/// Evaluation is a template on the number type, so that the trainer can differentiate through the
/// very function the runtime runs.

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "imm/core/physical_limits.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// One rule of eq. (13): Gaussian premises on r and Δr, a constant consequent w.
struct IMM_RUNTIME_EXPORT FuzzyRule {
  double c1 = 0.0;      ///< center on the residual r
  double sigma1 = 1.0;  ///< spread on r, > 0
  double c2 = 0.0;      ///< center on the residual change Δr
  double sigma2 = 1.0;  ///< spread on Δr, > 0
  double w = 0.0;       ///< consequent: process-noise variance, ≥ 0
};

/// q(r, Δr) of eq. (19-5) over `count` rules, with the mean-w fallback.
template <class Scalar>
[[nodiscard]] Scalar fuzzy_inference(const FuzzyRule* rules, std::size_t count, const Scalar& r,
                                     const Scalar& dr, double mean_w) {
  Scalar numerator(0.0), denominator(0.0);
  for (std::size_t l = 0; l < count; ++l) {
    const FuzzyRule& rule = rules[l];
    const Scalar a = (r - rule.c1) / rule.sigma1;
    const Scalar b = (dr - rule.c2) / rule.sigma2;
    using std::exp;
    const Scalar firing = exp(-0.5 * (a * a + b * b));  // μ₁ μ₂ in one exponential
    numerator += rule.w * firing;
    denominator += firing;
  }
  if (!(denominator >= std::numeric_limits<double>::min())) return Scalar(mean_w);
  return numerator / denominator;
}

/// A validated table: 1 to kMaxRules rules, finite, σ > 0, w ≥ 0.
class IMM_RUNTIME_EXPORT FuzzyRuleTable {
 public:
  /// The most rules a table may hold.
  static constexpr std::size_t kMaxRules = 50;

  FuzzyRuleTable() = default;
  /// Throws std::invalid_argument naming the rule and field ("rule 3 sigma1 …").
  explicit FuzzyRuleTable(std::vector<FuzzyRule> rules) : rules_(std::move(rules)) {
    if (rules_.empty() || rules_.size() > kMaxRules) {
      throw std::invalid_argument("a fuzzy rule table needs 1 to " + std::to_string(kMaxRules) +
                                  " rules, got " + std::to_string(rules_.size()));
    }
    double sum = 0.0;
    for (std::size_t l = 0; l < rules_.size(); ++l) {
      const FuzzyRule& rule = rules_[l];
      const std::string name = "rule " + std::to_string(l);
      // Residuals are distances, the consequents w process-noise variances.
      if (!limits::contains(limits::kDistance, std::abs(rule.c1)) ||
          !limits::contains(limits::kDistance, std::abs(rule.c2))) {
        throw std::invalid_argument(name + ": centers must be finite with magnitude in " +
                                    limits::describe(limits::kDistance));
      }
      if (!limits::contains(limits::kSigma, rule.sigma1) ||
          !limits::contains(limits::kSigma, rule.sigma2)) {
        throw std::invalid_argument(name + ": sigma1 and sigma2 must be positive, in " +
                                    limits::describe(limits::kSigma));
      }
      if (!limits::contains(limits::kVariance, rule.w)) {
        throw std::invalid_argument(name + ": w must be non-negative and finite, in " +
                                    limits::describe(limits::kVariance));
      }
      sum += rule.w;
    }
    mean_w_ = sum / static_cast<double>(rules_.size());
  }

  /// q(r, Δr), eq. (19-5).
  template <class Scalar = double>
  [[nodiscard]] Scalar process_noise(const Scalar& r, const Scalar& dr) const {
    return fuzzy_inference(rules_.data(), rules_.size(), r, dr, mean_w_);
  }

  /// The rules.
  [[nodiscard]] const std::vector<FuzzyRule>& rules() const { return rules_; }
  /// The number of rules.
  [[nodiscard]] std::size_t size() const { return rules_.size(); }
  /// The mean consequent w: the answer far from every rule.
  [[nodiscard]] double mean_w() const { return mean_w_; }

 private:
  std::vector<FuzzyRule> rules_;
  double mean_w_ = 0.0;
};

}  // namespace imm
