// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The GA-fuzzy IMM's idea on the tuned CV/CA/CT IMM: each mode's Q scheduled by a fuzzy rule
/// table of the mode's normalized innovation d and its change Δd
/// (imm/estimation/scheduled_noise_mode.hpp), learned on the training split on top of the tuned
/// classical IMM and kept only when it improves the validation split.
///
/// The tables: a 3 × 3 grid of Gaussian premises — d at 0.75, 2 and 3.5 (σ 0.6), where a χ with
/// two degrees of freedom has its bulk, its 95 % point and its far tail; Δd at −1.5, 0 and 1.5
/// (σ 0.8) — whose consequents are the learned multipliers s = 2^x, x ∈ [−4, 4]. The search starts
/// at x = 0, the tuned IMM itself, and runs Subplex on the classical objective (ζ_p + ζ_v with
/// truth, the excess NLL without); the grid's premises stay fixed, so that the consequents alone
/// are learned (9 per mode) and the tables mean the same on every regime.

#include <vector>

#include "imm/datasets/track.hpp"
#include "imm/filters/plain_imm.hpp"
#include "imm/trainer/classical/classical_imm.hpp"

namespace imm::trainer::classical {

/// Rules per mode's table.
inline constexpr int kScheduleRules = 9;

/// The grid's table with every consequent 2^x[l] (x empty: all 1, the unscheduled mode).
[[nodiscard]] FuzzyRuleTable schedule_table(const std::vector<double>& x = {});

/// `base` with mode j's table from x[9j … 9j + 8].
[[nodiscard]] PlainImmSpec scheduled_spec(const PlainImmSpec& base, const std::vector<double>& x);

/// What the schedule's learning found.
struct LearnedSchedule {
  PlainImmSpec spec;                           ///< the scheduled IMM if kept, else the base itself
  bool on = false;                             ///< kept: it improved the validation objective
  ClassicalScore training_base, training;      ///< base and scheduled, training split
  ClassicalScore validation_base, validation;  ///< base and scheduled, validation split
  int evaluations = 0;
};

/// Learns the schedules of every mode of `base` (no Singer modes) on `training` with a Subplex
/// budget of `evaluations`, and keeps them if they lower the objective on `validation`.
[[nodiscard]] LearnedSchedule learn_noise_schedule(const PlainImmSpec& base,
                                                   const datasets::TrackSet& training,
                                                   const datasets::TrackSet& validation,
                                                   int evaluations);

}  // namespace imm::trainer::classical
