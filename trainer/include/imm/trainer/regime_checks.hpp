// SPDX-License-Identifier: Apache-2.0
#pragma once
/// What a kind of model needs of a regime, checked when its config loads (InvalidParameter naming
/// the config's `regime` key, so the user sees which regime and why).

#include <string>

#include "imm/datasets/regime.hpp"
#include "imm/datasets/track.hpp"

namespace imm::trainer {

/// The per-axis filters (GA-fuzzy IMM, input estimator, FCM-IMM): Cartesian plots with one σ on
/// both axes, uncorrelated, the same in every case. `kind` names the filter in the message.
void require_per_axis_sensor(const datasets::Regime& regime, const std::string& kind);

/// A sensor of the given kind (the weighted IMM: polar; the FIMM: a range sensor).
void require_sensor(const datasets::Regime& regime, datasets::SensorKind sensor,
                    const std::string& kind);

/// Training and tuning learn from the truth of a regime's training and validation splits. A
/// recorded regime allows that only when its set has truth and `recorded.truth = "training"`;
/// otherwise InvalidParameter naming `recorded.truth`, with `who` (the trainer or the tuned
/// baseline) in the message. Drawn regimes always pass.
void require_training_truth(const datasets::Regime& regime, const std::string& who);

/// Training from plots alone steps every plot of a window: a window with a gap (NaN plots) is
/// refused (std::runtime_error naming the regime's file and the recording).
void require_gap_free(const datasets::Regime& regime, const datasets::TrackSet& set);

/// An acceleration scale of the regime for the defaults and search boxes that depend on it: its
/// largest commanded acceleration, else ten times its truth noise, else one unit.
[[nodiscard]] double acceleration_scale(const datasets::Regime& regime);

}  // namespace imm::trainer
