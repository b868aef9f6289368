// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The tuned classical filter of a regime as a model file of its own (`imm-train baseline`): the
/// constant-q IMM, per axis, whose levels and stay probability are tuned on the regime's training
/// split exactly as the evaluation's IMM-tuned and the GA trainer's starting point
/// (tuned_levels.hpp). It is written in the GA-fuzzy IMM's file form with one constant rule per
/// level — the form in which that IMM is a loadable filter — and its provenance says it has no
/// learned part (`training.learned_part_on` = 0, `training.classical_baseline` = 1), so that the
/// regime's tracker can be chosen among the learned models *and* this baseline on equal terms.

#include <filesystem>

#include "imm/trainer/ga/ga_config.hpp"

namespace imm::trainer::ga {

struct TunedBaselineResult {
  TunedBaseline baseline;  ///< the tuned q_j, stay and training score
  double wall_seconds = 0.0;
  std::string criterion;  ///< what the score is (TrainingSet::criterion)
};

/// Tunes the baseline of `config` (its regime, level_count and search budget; `levels = "tuned"`
/// is implied) on the training split and writes it to `out` atomically, with `out`.metrics.json.
TunedBaselineResult write_tuned_baseline(GaTrainingConfig config, const std::filesystem::path& out);

}  // namespace imm::trainer::ga
