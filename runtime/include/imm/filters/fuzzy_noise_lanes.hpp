// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The GA-fuzzy IMM's per-mode arithmetic over W independent axis filters at once (lanes): the
/// mixing of eq. (4–6) and the fuzzy-noise step of fuzzy_noise_filter.hpp (prediction, the rule
/// table's q, the Joseph update with H = [1 0]) in the order of FuzzyNoiseFilter::step and
/// update_with_innovation, written as loops over lanes with no branches and no calls, which the
/// compiler vectorizes. Used by the runtime's GaFuzzyTrackBank (many tracks) and by the trainer's
/// GA fitness batch (many trajectories), so the two run the same arithmetic.
///
/// Differences to the one-track filter are rounding only: exp is lane_exp (lane_math.hpp, within
/// 2 ulp of libm's), and the rules' spreads and S are inverted once and multiplied.

#include <cmath>
#include <cstddef>
#include <limits>

#include "imm/core/physical_limits.hpp"
#include "imm/estimation/cv_axis_lanes.hpp"
#include "imm/filters/fuzzy_noise_filter.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/models/learned/fuzzy_rule_table.hpp"
#include "imm/models/motion/constant_velocity.hpp"

namespace imm::lanes {

/// What every mode of an axis shares: T, R = σ_z², G Gᵀ, and what the tables read.
struct FuzzyAxisConstants {
  double T = 1.0;           ///< sample period, s
  double R = 1.0;           ///< σ_z²
  double g00 = 0.0;         ///< (G Gᵀ)₀₀ of cv_axis_input_gain
  double g01 = 0.0;         ///< (G Gᵀ)₀₁
  double g11 = 0.0;         ///< (G Gᵀ)₁₁
  bool normalized = false;  ///< FuzzyAntecedents::kNormalizedInnovation

  /// T = 1, R = 1, no process noise.
  FuzzyAxisConstants() = default;
  /// The constants of an axis with sample period T, plot σ and antecedents.
  FuzzyAxisConstants(double sample_period, double measurement_sigma, FuzzyAntecedents antecedents)
      : T(sample_period),
        R(measurement_sigma * measurement_sigma),
        normalized(antecedents == FuzzyAntecedents::kNormalizedInnovation) {
    const Vector<2> G = cv_axis_input_gain(T);
    g00 = G(0) * G(0);
    g01 = G(0) * G(1);
    g11 = G(1) * G(1);
  }
};

/// One level's rule table, its spreads inverted (a multiplication per rule instead of a division).
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

/// What one fuzzy-noise step gives per lane besides the mode's new state.
template <int W>
struct FuzzyStep {
  double exponent[W];   ///< −½ r² / S
  double s[W];          ///< S = H P⁻ Hᵀ + R
  double s_inverse[W];  ///< 1 / S
  /// 1 where S is positive and finite (else the step is kSingularInnovation).
  double usable[W];
  /// 1 where every output is finite (else kNonFiniteResult).
  double finite[W];
};

/// One fuzzy-noise step (fuzzy_noise_filter.hpp, eq. 19) of mode j from its mixed condition
/// [m0, m1], [[c00, c01], [c01, c11]] with plots z and the mode's previous antecedents: mode j of
/// `next` receives the new state, `out` the rest.
template <int W>
[[gnu::always_inline]] inline void fuzzy_noise_step(
    const FuzzyAxisConstants& a, const FuzzyLevelConstants& level, const double* z,
    const double* previous, const double (&m0)[W], const double (&m1)[W], const double (&c00)[W],
    const double (&c01)[W], const double (&c11)[W], int j, AxisModes<W>& next, FuzzyStep<W>& out) {
  double* __restrict antecedent = next.previous[j];
  const double T = a.T;
  // Prediction F x, F P Fᵀ; the residual and the table's inputs.
  double a0[W], residual[W], q00[W], q01[W], q11[W];
  IMM_LANES {
    const AxisEstimate predicted = cv_predict(T, {m0[l], m1[l], c00[l], c01[l], c11[l]});
    a0[l] = predicted.x0;
    q00[l] = predicted.p00;
    q01[l] = predicted.p01;
    q11[l] = predicted.p11;
    residual[l] = z[l] - a0[l];
    antecedent[l] = a.normalized ? residual[l] / std::sqrt(q00[l] + a.R) : residual[l];
  }
  // q(k) of the rule table (eq. 19-5), the mean w where no rule fires.
  double numerator[W], denominator[W];
  IMM_LANES numerator[l] = denominator[l] = 0.0;
  for (int rule = 0; rule < level.rule_count; ++rule) {
    const FuzzyLevelConstants::Rule& f = level.rules[rule];
    IMM_LANES {
      const double u = (antecedent[l] - f.c1) * f.inverse_sigma1;
      const double v = (antecedent[l] - previous[l] - f.c2) * f.inverse_sigma2;
      const double firing = lane_exp(-0.5 * (u * u + v * v));
      numerator[l] += f.w * firing;
      denominator[l] += firing;
    }
  }
  IMM_LANES {
    const double q = pick(denominator[l] >= std::numeric_limits<double>::min(),
                          numerator[l] / denominator[l], level.mean_w);
    q00[l] += q * a.g00;
    q01[l] += q * a.g01;
    q11[l] += q * a.g11;
    // The Kalman update with H = [1 0] in the order of update_with_innovation.
    double S, S_inverse;
    const AxisEstimate e =
        position_update({a0[l], m1[l], q00[l], q01[l], q11[l]}, a.R, residual[l], S, S_inverse);
    next.x0[j][l] = e.x0;
    next.x1[j][l] = e.x1;
    next.p00[j][l] = e.p00;
    next.p01[j][l] = e.p01;
    next.p11[j][l] = e.p11;
    out.exponent[l] = -0.5 * (residual[l] * (S_inverse * residual[l]));
    out.s[l] = S;
    out.s_inverse[l] = S_inverse;
    out.usable[l] = pick((S > 0.0) & (S < std::numeric_limits<double>::infinity()), 1.0, 0.0);
    out.finite[l] =
        pick(std::isfinite(e.x0 + e.x1 + e.p00 + e.p01 + e.p11 + out.exponent[l]), 1.0, 0.0);
  }
}

}  // namespace imm::lanes
