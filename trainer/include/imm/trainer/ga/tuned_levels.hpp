// SPDX-License-Identifier: Apache-2.0
#pragma once
/// A GA-fuzzy IMM that contains its tuned baseline (`[training] levels = "tuned"`, see
/// GaTrainingConfig::tuned_levels): the constant-q IMM tuned on the training split gives the
/// levels and the stay probability, the tables are learned on top of it, the levels and the stay
/// are then refined with the tables, and the result is kept only when it beats that IMM on the
/// validation split.

#include <optional>
#include <string>
#include <vector>

#include "imm/filters/ga_fuzzy_imm.hpp"
#include "imm/trainer/ga/ga_config.hpp"

namespace imm::trainer::ga {

/// For `levels = "tuned"`: tunes the baseline on `training` (once; a config whose baseline is set
/// is returned as it is) and fills levels, baseline and filter.transition_stay. Other configs are
/// returned unchanged.
[[nodiscard]] GaTrainingConfig resolve_levels(GaTrainingConfig config, const TrainingSet& training);

/// The tuned IMM as a GA-fuzzy IMM spec: one constant rule q_j per level (the widest premise at
/// the origin; a one-rule table answers its consequent everywhere) and the tuned stay probability.
/// Needs a resolved config.
[[nodiscard]] GaFuzzyImmSpec tuned_baseline_spec(const GaTrainingConfig& config);

/// The joint refinement of `[training] refine_levels`: one factor per level on its table's
/// consequents and the stay probability, on the whole IMM's ζ_p + ζ_v over the training split.
struct LevelRefinement {
  Evaluation before, after;     ///< the IMM of every level's table (rules: their total)
  std::vector<double> factors;  ///< per level, on w (1: unchanged)
  double transition_stay = 0.0;
  int evaluations = 0;
  bool accepted = false;  ///< after beat before (otherwise nothing changed)
};

/// Subplex over (log10 factor per level within a decade either way, log10(1 − p_jj) with
/// p_jj ∈ [0.5, 1 − 10⁻⁴]) from the spec as it is, with the config's memetic budget (at least 50
/// evaluations); `spec` changes only when ζ_p + ζ_v improves. A tuned level's maneuver_level (its
/// √q) moves with its factor.
LevelRefinement refine_levels(GaFuzzyImmSpec& spec, const GaTrainingConfig& config,
                              const TrainingSet& training);

/// The learned IMM against the tuned IMM it started from, on the validation split, by ζ_p + ζ_v
/// (the evaluation's figure, whatever error the GA used). The tables are kept only when they are
/// better there; otherwise every level gets its constant rule q_j back and the model *is* the
/// tuned IMM — its learned part switched off, which the log, the metrics, the model file
/// (`training.learned_part_on` = 0) and the evaluation report say.
struct BaselineCheck {
  Evaluation learned, baseline;  ///< the whole IMM on the validation split
  /// Without truth also the innovation RMS in plot σ (axis_innovation_rms) of both.
  double learned_innovation_rms = 0.0, baseline_innovation_rms = 0.0;
  bool learned_part_on = true;
};

/// Replaces `spec` by tuned_baseline_spec(config) when it does not beat it on `validation`: a
/// lower ζ_p + ζ_v, or — without truth — a lower excess NLL per plot *and* an innovation RMS no
/// higher (the likelihood also rewards a better-calibrated S; the tables must not buy it with
/// worse predictions, the rule of imm-eval rank's two criteria).
BaselineCheck check_against_baseline(GaFuzzyImmSpec& spec, const GaTrainingConfig& config,
                                     const TrainingSet& validation);

/// For levels the config did not tune (`"auto"` or a list): a warning when the quietest level
/// cannot reach the quietest behaviour of its regime — its lowest consequent, (consequent_low ·
/// (a_M + √q))², lies more than ten times above the lowest q of the constant-q IMM tuned on
/// `training` (tune_axis_cv_imm, the same search as `levels = "tuned"`). Such a model cannot be
/// as quiet as that IMM on straight flight, whatever its tables. Empty when it can, and for tuned
/// levels.
[[nodiscard]] std::optional<std::string> unreachable_quiet_level(const GaTrainingConfig& config,
                                                                 const TrainingSet& training);

}  // namespace imm::trainer::ga
