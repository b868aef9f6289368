// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The GA-fuzzy IMM of seed 000 §3.2 (SPEC §4.1): per axis an IMM whose modes are fuzzy-noise KFs
/// (fuzzy_noise_filter.hpp), one learned rule table per maneuver level; transition and initial
/// probabilities by eq. (20)–(21); the two axes behind one 2-D filter.

#include <memory>
#include <string>
#include <vector>

#include "imm/filters/axis_filter.hpp"
#include "imm/filters/fuzzy_noise_filter.hpp"
#include "imm/models/learned/fuzzy_rule_table.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/tracker.hpp"

namespace imm {

/// One maneuver level of the GA-fuzzy IMM: a rule table trained for one acceleration input.
struct IMM_RUNTIME_EXPORT FuzzyLevel {
  std::string name;             ///< e.g. "u0.01"
  double maneuver_level = 0.0;  ///< the acceleration input u the table was trained for
  /// The trained rule table.
  FuzzyRuleTable table;
};

/// The GA-fuzzy IMM of seed 000: one fuzzy-noise mode per maneuver level, per axis.
struct IMM_RUNTIME_EXPORT GaFuzzyImmSpec {
  /// Sample period, plot σ and mode switching of the axis IMM.
  AxisImmSettings settings;
  std::vector<FuzzyLevel> levels;  ///< one IMM mode per level, 1 to 8
  /// What every level's table reads (fuzzy_noise_filter.hpp): the seed's raw residuals, or
  /// normalized innovations.
  FuzzyAntecedents antecedents = FuzzyAntecedents::kResidual;

  /// Throws InvalidParameter naming the field.
  void validate() const;
  /// Cartesian plots, two-point initialization (AxisImmSettings::track_options).
  [[nodiscard]] TrackOptions track_options(std::int64_t max_gap = kDefaultMaxGap) const {
    return settings.track_options(max_gap);
  }
};

/// The per-axis IMM (modes in level order).
[[nodiscard]] IMM_RUNTIME_EXPORT ImmEstimator<2, 1> build_ga_fuzzy_axis_imm(
    const GaFuzzyImmSpec& spec);

/// The 2-D filter: the per-axis IMM on x and on y.
[[nodiscard]] IMM_RUNTIME_EXPORT std::unique_ptr<TwoAxisFilter> make_ga_fuzzy_imm_filter(
    const GaFuzzyImmSpec& spec);

}  // namespace imm
