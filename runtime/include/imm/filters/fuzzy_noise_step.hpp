// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The fuzzy-noise step of seed 000 §3.2 (fuzzy_noise_filter.hpp: prediction, the rule table's q,
/// the Joseph update with H = [1 0]) written once over a number type S: a double for one filter
/// (FuzzyNoiseFilter::step), a pack of lanes (lane_math.hpp) for many — the GaFuzzyTrackBank's
/// tracks and the trainer's GA fitness batch's trajectories, one per element. Beside it the
/// IMM mixing of eq. (4–6) over W lanes, which the banks and the fitness batch share.
///
/// The two instances differ in two primitives only: a double evaluates the rules as
/// fuzzy_inference does (libm's exp, a division by each σ), which the trained models' numbers
/// depend on; a pack multiplies by 1/σ and uses lane_exp (within 2 ulp of libm's), which keep the
/// vector loop free of divisions and calls. Every other operation is the same IEEE operation in
/// the same order (the project compiles with -ffp-contract=off).

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <utility>

#include "imm/core/physical_limits.hpp"
#include "imm/estimation/cv_axis_lanes.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/models/learned/fuzzy_rule_table.hpp"
#include "imm/models/motion/constant_velocity.hpp"

namespace imm {

/// What a rule table's two inputs are (fuzzy_noise_filter.hpp's file comment).
enum class FuzzyAntecedents : std::uint8_t {
  kResidual,              ///< r and Δr in measurement units (seed 000's literal form)
  kNormalizedInnovation,  ///< r/√S̄ and its change: dimensionless
};

}  // namespace imm

namespace imm::lanes {

/// What every mode of an axis shares: T, R = σ_z², G Gᵀ, and what the tables read. The period and
/// the plot variance come from the spec (the regime or the model file): unset, they are NaN, so a
/// step from constants never built from one gives NaN, not a filter of some default period.
struct FuzzyAxisConstants {
  double T = std::numeric_limits<double>::quiet_NaN();  ///< sample period, s
  double R = std::numeric_limits<double>::quiet_NaN();  ///< σ_z²
  double g00 = 0.0;                                     ///< (G Gᵀ)₀₀ of cv_axis_input_gain
  double g01 = 0.0;                                     ///< (G Gᵀ)₀₁
  double g11 = 0.0;                                     ///< (G Gᵀ)₁₁
  bool normalized = false;                              ///< FuzzyAntecedents::kNormalizedInnovation

  /// Unset: T and R NaN, no process noise.
  FuzzyAxisConstants() = default;
  /// The constants of an axis with sample period T, plot variance R = σ_z² and antecedents.
  FuzzyAxisConstants(double sample_period, double measurement_variance,
                     FuzzyAntecedents antecedents)
      : T(sample_period),
        R(measurement_variance),
        normalized(antecedents == FuzzyAntecedents::kNormalizedInnovation) {
    const Vector<2> G = cv_axis_input_gain(T);
    g00 = G(0) * G(0);
    g01 = G(0) * G(1);
    g11 = G(1) * G(1);
  }
};

/// One level's rule table as a pack reads it: its spreads inverted (a multiplication per rule
/// instead of a division).
struct FuzzyLevelConstants {
  /// One rule (FuzzyRule) with 1/σ in place of σ.
  struct Rule {
    double c1;              ///< centre of the first input
    double inverse_sigma1;  ///< 1/σ₁
    double c2;              ///< centre of the second input
    double inverse_sigma2;  ///< 1/σ₂
    double w;               ///< consequent q
  };
  Rule rules[FuzzyRuleTable::kMaxRules] = {};  ///< the first rule_count are the table
  int rule_count = 0;                          ///< rules in the table
  double mean_w = 0.0;                         ///< q where no rule fires

  /// An empty table.
  FuzzyLevelConstants() = default;
  /// The constants of `table`.
  explicit FuzzyLevelConstants(const FuzzyRuleTable& table)
      : rule_count(static_cast<int>(table.size())), mean_w(table.mean_w()) {
    for (std::size_t k = 0; k < table.size(); ++k) {
      const FuzzyRule& rule = table.rules()[k];
      rules[k] = {rule.c1, 1.0 / rule.sigma1, rule.c2, 1.0 / rule.sigma2, rule.w};
    }
  }
};

/// One level's rule table as a double reads it: the table's own rules (FuzzyRule, with σ).
struct FuzzyTableRules {
  const FuzzyRule* rules = nullptr;  ///< the table's rules
  int rule_count = 0;                ///< how many
  double mean_w = 0.0;               ///< q where no rule fires

  /// The rules of `table`, which must outlive this.
  explicit FuzzyTableRules(const FuzzyRuleTable& table)
      : rules(table.rules().data()),
        rule_count(static_cast<int>(table.size())),
        mean_w(table.mean_w()) {}
};

/// The most levels (modes per axis) a GA-fuzzy IMM has (GaFuzzyImmSpec::validate).
inline constexpr int kMaxLevels = 8;

/// The state of up to kMaxLevels fuzzy-noise modes over W lanes: mode j's estimate
/// [x0, x1], [[p00, p01], [p01, p11]] and its table's last first input (the next step's
/// `previous`) at [j][lane].
template <int W>
struct AxisModes {
  double x0[kMaxLevels][W];        ///< position
  double x1[kMaxLevels][W];        ///< velocity
  double p00[kMaxLevels][W];       ///< covariance P₀₀
  double p01[kMaxLevels][W];       ///< P₀₁
  double p11[kMaxLevels][W];       ///< P₁₁
  double previous[kMaxLevels][W];  ///< the table's first input at the last step
};

/// The mixed initial condition of one mode (eq. 4–5) over W lanes: mean [m0, m1], covariance
/// [[c00, c01], [c01, c11]]. `weight[i]` are the weights μ_{i|j} of the n modes' estimates in
/// `modes` (the combination of eq. 10–11 is the same sum with μ_j). A zero weight contributes
/// nothing, as in ImmEstimator.
template <int W>
[[gnu::always_inline]] inline void mix(int n, const double (*weight)[W], const AxisModes<W>& modes,
                                       double (&m0)[W], double (&m1)[W], double (&c00)[W],
                                       double (&c01)[W], double (&c11)[W]) {
  IMM_LANES m0[l] = m1[l] = c00[l] = c01[l] = c11[l] = 0.0;
  for (int i = 0; i < n; ++i) {
    IMM_LANES {
      m0[l] += weight[i][l] * modes.x0[i][l];
      m1[l] += weight[i][l] * modes.x1[i][l];
    }
  }
  for (int i = 0; i < n; ++i) {
    IMM_LANES {
      const double w = weight[i][l];
      const double d0 = modes.x0[i][l] - m0[l], d1 = modes.x1[i][l] - m1[l];
      c00[l] += pick(w == 0.0, 0.0, w * (modes.p00[i][l] + d0 * d0));
      c01[l] += pick(w == 0.0, 0.0, w * (modes.p01[i][l] + d0 * d1));
      c11[l] += pick(w == 0.0, 0.0, w * (modes.p11[i][l] + d1 * d1));
    }
  }
}

/// A rule's scaled distances (r − c₁)/σ₁ and (Δr − c₂)/σ₂: a double divides by σ (as
/// fuzzy_inference, reading FuzzyTableRules), a pack multiplies by 1/σ (reading
/// FuzzyLevelConstants; see the file comment).
template <class S, class Rule>
[[gnu::always_inline]] inline void scaled_inputs(const Rule& f, S r, S dr, S& u, S& v) {
  if constexpr (std::is_same_v<S, double>) {
    u = (r - f.c1) / f.sigma1;
    v = (dr - f.c2) / f.sigma2;
  } else {
    u = (r - f.c1) * f.inverse_sigma1;
    v = (dr - f.c2) * f.inverse_sigma2;
  }
}

/// eˣ of a firing strength's exponent (x ≤ 0 or NaN): libm's for a double, lane_exp for a pack
/// (see the file comment; lane_exp_no_overflow, its bits for such an x).
template <class S>
[[gnu::always_inline]] inline S fuzzy_exp(S x) {
  if constexpr (std::is_same_v<S, double>) {
    return std::exp(x);
  } else {
    return lane_exp_no_overflow(x);
  }
}

/// What one fuzzy-noise step gives (per element for a pack).
template <class S>
struct FuzzyNoiseStep {
  AxisEstimateOf<S> estimate;  ///< the updated estimate
  /// The table's first input: r, or r/√S̄ (normalized antecedents); the next step's `previous`.
  S antecedent;
  S residual;       ///< r = z − H x̂⁻
  S process_noise;  ///< q(k)
  S s;              ///< S = H P⁻ Hᵀ + R
  S s_inverse;      ///< 1 / S
  S mahalanobis;    ///< r² / S, as r (S⁻¹ r)
  /// S positive and finite (else the step is kSingularInnovation): a bool, or a pack's mask.
  decltype(std::declval<S>() > 0.0) usable;
  /// The estimate finite with no negative variance (else kNonFiniteResult), as
  /// GaussianState::usable.
  decltype(std::declval<S>() > 0.0) finite;
};

/// K independent fuzzy-noise steps (eq. 19) from the mixed conditions `mixed` with plots z and
/// the modes' previous antecedents (0 on a new track), each in the order of
/// FuzzyNoiseFilter::step: F x̂, F P Fᵀ, r, the table's inputs and q(k) of eq. (19-5) (the mean w
/// where the total firing strength is below the smallest normal double, as fuzzy_inference), P⁻
/// += q G Gᵀ, the update with innovation r. The K steps advance phase by phase and rule by rule
/// together: their chains of operations are independent, and a core overlaps them (K packs of
/// lanes for a wide block; K = 1 for one filter). `level`: FuzzyTableRules for a double,
/// FuzzyLevelConstants for a pack.
template <class S, int K, class Level>
[[gnu::always_inline]] inline void fuzzy_noise_steps(const FuzzyAxisConstants& a,
                                                     const Level& level, const S (&z)[K],
                                                     const S (&previous)[K],
                                                     const AxisEstimateOf<S> (&mixed)[K],
                                                     FuzzyNoiseStep<S> (&out)[K]) {
  AxisEstimateOf<S> predicted[K];
  S change[K], numerator[K], denominator[K];
  for (int k = 0; k < K; ++k) {
    predicted[k] = cv_predict<S>(a.T, mixed[k]);
    out[k].residual = z[k] - predicted[k].x0;
    out[k].antecedent = out[k].residual;
    numerator[k] = denominator[k] = splat<S>(0.0);
  }
  if (a.normalized) {
    // S̄ ≥ R > 0 for a PSD covariance; a non-finite S̄ propagates to a failed update below.
    for (int k = 0; k < K; ++k) {
      out[k].antecedent = out[k].residual / lane_sqrt(predicted[k].p00 + a.R);
    }
  }
  for (int k = 0; k < K; ++k) change[k] = out[k].antecedent - previous[k];
  for (int rule = 0; rule < level.rule_count; ++rule) {
    const auto& f = level.rules[rule];
    for (int k = 0; k < K; ++k) {
      S u, v;
      scaled_inputs(f, out[k].antecedent, change[k], u, v);
      const S firing = fuzzy_exp<S>(-0.5 * (u * u + v * v));  // μ₁ μ₂ in one exponential
      numerator[k] += f.w * firing;
      denominator[k] += firing;
    }
  }
  for (int k = 0; k < K; ++k) {
    const S q = pick(denominator[k] >= std::numeric_limits<double>::min(),
                     numerator[k] / denominator[k], level.mean_w);
    out[k].process_noise = q;
    predicted[k].p00 = predicted[k].p00 + q * a.g00;
    predicted[k].p01 = predicted[k].p01 + q * a.g01;
    predicted[k].p11 = predicted[k].p11 + q * a.g11;
    out[k].estimate =
        position_update<S>(predicted[k], a.R, out[k].residual, out[k].s, out[k].s_inverse);
    out[k].mahalanobis = out[k].residual * (out[k].s_inverse * out[k].residual);
    // 0 < S < ∞ as one comparison (lane_log says why not two joined by &).
    constexpr double kInf = std::numeric_limits<double>::infinity();
    out[k].usable = pick(out[k].s > 0.0, out[k].s, kInf) < kInf;
    const AxisEstimateOf<S>& e = out[k].estimate;
    // Every entry finite (x·0 is 0 for a finite x, NaN otherwise; the sum of zeros cannot
    // overflow) and no negative variance: GaussianState::usable.
    const S zeros = e.x0 * 0.0 + e.x1 * 0.0 + e.p00 * 0.0 + e.p01 * 0.0 + e.p11 * 0.0;
    out[k].finite = zeros + pick(e.p00 >= 0.0, 0.0, 1.0) + pick(e.p11 >= 0.0, 0.0, 1.0) == 0.0;
  }
}

/// One fuzzy-noise step (fuzzy_noise_steps with K = 1).
template <class S, class Level>
[[gnu::always_inline]] inline FuzzyNoiseStep<S> fuzzy_noise_step(const FuzzyAxisConstants& a,
                                                                 const Level& level, S z,
                                                                 S previous,
                                                                 const AxisEstimateOf<S>& mixed) {
  const S zs[1] = {z}, previous_s[1] = {previous};
  const AxisEstimateOf<S> mixed_s[1] = {mixed};
  FuzzyNoiseStep<S> out[1];
  fuzzy_noise_steps<S, 1>(a, level, zs, previous_s, mixed_s, out);
  return out[0];
}

/// What mode j's fuzzy-noise steps over W lanes give besides the mode's new state.
template <int W>
struct FuzzyLaneSteps {
  double mahalanobis[W];  ///< r² / S
  double s[W];            ///< S = H P⁻ Hᵀ + R
  double s_inverse[W];    ///< 1 / S
  double usable[W];       ///< 1 where S is positive and finite (else kSingularInnovation)
  double finite[W];       ///< 1 where the estimate is usable (else kNonFiniteResult)
};

/// Mode j's fuzzy-noise steps over W lanes (whole packs) from its mixed conditions [m0, m1],
/// [[c00, c01], [c01, c11]] with plots z and the mode's previous antecedents in `now`:
/// fuzzy_noise_steps over packs of `Pack` (one vector of the instruction set that runs it,
/// lane_isa.hpp: a wider pack has no register and its comparisons become scalar code; by default
/// 8, or W below 8), all stepped together. Mode j of `next` receives the new states and
/// antecedents, `out` the rest.
template <int W, class Pack = LanePackOf<(W < kLanePackWidth ? W : kLanePackWidth)>>
[[gnu::always_inline]] inline void fuzzy_noise_lanes(const FuzzyAxisConstants& a,
                                                     const FuzzyLevelConstants& level,
                                                     const double* z, const double (&m0)[W],
                                                     const double (&m1)[W], const double (&c00)[W],
                                                     const double (&c01)[W], const double (&c11)[W],
                                                     int j, const AxisModes<W>& now,
                                                     AxisModes<W>& next, FuzzyLaneSteps<W>& out) {
  constexpr int kPack = kLanesOf<Pack>, K = W / kPack;
  static_assert(K * kPack == W, "W is whole packs");
  Pack zs[K], previous[K];
  AxisEstimateOf<Pack> mixed[K];
  FuzzyNoiseStep<Pack> step[K];
  for (int p = 0; p < K; ++p) {
    const int o = p * kPack;
    zs[p] = lane_load<Pack>(z + o);
    previous[p] = lane_load<Pack>(now.previous[j] + o);
    mixed[p] = {lane_load<Pack>(m0 + o), lane_load<Pack>(m1 + o), lane_load<Pack>(c00 + o),
                lane_load<Pack>(c01 + o), lane_load<Pack>(c11 + o)};
  }
  fuzzy_noise_steps<Pack, K>(a, level, zs, previous, mixed, step);
  for (int p = 0; p < K; ++p) {
    const int o = p * kPack;
    lane_store(next.x0[j] + o, step[p].estimate.x0);
    lane_store(next.x1[j] + o, step[p].estimate.x1);
    lane_store(next.p00[j] + o, step[p].estimate.p00);
    lane_store(next.p01[j] + o, step[p].estimate.p01);
    lane_store(next.p11[j] + o, step[p].estimate.p11);
    lane_store(next.previous[j] + o, step[p].antecedent);
    lane_store(out.mahalanobis + o, step[p].mahalanobis);
    lane_store(out.s + o, step[p].s);
    lane_store(out.s_inverse + o, step[p].s_inverse);
    lane_store(out.usable + o, pick(step[p].usable, 1.0, 0.0));
    lane_store(out.finite + o, pick(step[p].finite, 1.0, 0.0));
  }
}

}  // namespace imm::lanes
