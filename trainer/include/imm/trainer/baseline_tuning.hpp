// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The seed-000 classical filters tuned on a training split: the baselines the evaluation compares
/// the GA-fuzzy IMM with, and the filter the GA trainer starts from (`levels = "tuned"`), so that
/// the learned model with one constant rule per level *is* the tuned IMM. The objective is ζ_p +
/// ζ_v (seed 000's normalized errors) of the per-axis filter over the one-axis training
/// trajectories — never the evaluation runs. Search: a log-spaced grid, then NLopt's Subplex from
/// the best grid point.

#include <functional>
#include <memory>
#include <vector>

#include "imm/filters/aimm.hpp"
#include "imm/filters/axis_cv_imm.hpp"
#include "imm/trainer/training_set.hpp"

namespace imm::trainer {

using AxisFilterFactory = std::function<std::unique_ptr<AxisFilter>()>;

/// ζ_p and ζ_v of a per-axis filter over one-axis trajectories (two-point start at scans 0, 1);
/// +∞ when a step fails. Without truth (plots_only sets, all of them or none) `position` is the
/// excess NLL per plot, −1/N Σ (log p(z | Z^(k−1)) + TrainingSet::nll_floor())
/// (AxisFilter::log_predictive_likelihood), and `velocity` 0: every tuner that minimizes
/// ζ_p + ζ_v then maximizes the plots' likelihood.
struct AxisZetas {
  double position = 0.0;
  double velocity = 0.0;
};
[[nodiscard]] AxisZetas axis_zetas(const AxisFilterFactory& make_filter,
                                   const std::vector<TrainingSet>& sets);
/// √(1/N Σ ν²) / σ_z over the same plots: the RMS of the filter's one-step prediction error of the
/// plots (AxisFilter::innovation, ν = z − ẑ), in plot σ — the accuracy a set without truth still
/// shows (E ν² = the predicted position's mean square error + σ_z²). +∞ when a step fails.
[[nodiscard]] double axis_innovation_rms(const AxisFilterFactory& make_filter,
                                         const std::vector<TrainingSet>& sets);
/// ζ_p + ζ_v of axis_zetas: the tuning objective.
[[nodiscard]] double axis_score(const AxisFilterFactory& make_filter,
                                const std::vector<TrainingSet>& sets);

template <class Spec>
struct Tuned {
  Spec spec;
  double score = 0.0;
  int evaluations = 0;
};

/// AIMM with 1 … max_intervals intervals ε_i ∈ [0.01 a, 3 a]; the best of the sizes. `a` is the
/// regime's acceleration scale (the seed's 0.1 km/s²: [1e-3, 0.3] km/s²).
[[nodiscard]] Tuned<AimmSpec> tune_aimm(const AimmSpec& base, const std::vector<TrainingSet>& sets,
                                        double a, int max_intervals = 2);

/// The stay probability's search box, as log10(1 − p_jj): p_jj ∈ [0.5, 1 − 10⁻⁴].
inline constexpr double kLogLeaveLow = -4.0;
inline constexpr double kLogLeaveHigh = -0.30102999566398120;  // log10(0.5)

/// What tune_axis_cv_imm searches besides the noise levels.
enum class TransitionTuning {
  kFixed,   ///< the base's stay probability
  kJointly  ///< the stay probability p_jj of eq. (20) with the levels, after them
};

/// Constant-q IMM with `levels` noise levels q_j ∈ [1e-8 a², 10 a²] (the seed's a: [1e-10, 0.1]
/// (km/s²)²) at the base's stay probability; with kJointly, Subplex then refines the levels and
/// the stay probability together (p_jj ∈ [0.5, 1 − 10⁻⁴], searched in log(1 − p_jj)) from that
/// optimum and keeps the result only when it scores better, so the joint search is never worse.
[[nodiscard]] Tuned<AxisCvImmSpec> tune_axis_cv_imm(
    const AxisCvImmSpec& base, const std::vector<TrainingSet>& sets, double a, int levels = 3,
    TransitionTuning transitions = TransitionTuning::kFixed);

/// The evaluations' IMM-tuned: three levels and the stay probability tuned jointly on `sets`, the
/// stay's search starting from AxisImmSettings' default (the configs' and the trainer's start)
/// whatever `settings` holds, so that a model learned on top of this IMM with its learned part off
/// is this IMM, not a second tuning of it.
[[nodiscard]] Tuned<AxisCvImmSpec> tune_imm_baseline(AxisImmSettings settings,
                                                     const std::vector<TrainingSet>& sets,
                                                     double a);

}  // namespace imm::trainer
