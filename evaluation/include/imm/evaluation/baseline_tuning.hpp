// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Tuning the seed-000 baselines on the model's training split, so that the learned filter is
/// compared with the strongest adaptive IMM and the best constant-noise IMM, not with hand-picked
/// ones. The objective is ζ_p + ζ_v (seed 000's normalized errors) of the per-axis filter over the
/// one-axis training trajectories of every maneuver level — the GA's own training data, never the
/// evaluation runs. Search: a log-spaced grid, then NLopt's Subplex from the best grid point.

#include <functional>
#include <memory>
#include <vector>

#include "imm/filters/aimm.hpp"
#include "imm/filters/axis_cv_imm.hpp"
#include "imm/trainer/ga/training_set.hpp"

namespace imm::evaluation {

using AxisFilterFactory = std::function<std::unique_ptr<AxisFilter>()>;

/// ζ_p + ζ_v of a per-axis filter over one-axis trajectories (two-point start at scans 0, 1).
[[nodiscard]] double axis_score(const AxisFilterFactory& make_filter,
                                const std::vector<trainer::ga::TrainingSet>& sets);

template <class Spec>
struct Tuned {
  Spec spec;
  double score = 0.0;
  int evaluations = 0;
};

/// AIMM with 1 … max_intervals intervals ε_i ∈ [0.01 a, 3 a]; the best of the sizes. `a` is the
/// regime's acceleration scale (the seed's 0.1 km/s²: [1e-3, 0.3] km/s²).
[[nodiscard]] Tuned<AimmSpec> tune_aimm(const AimmSpec& base,
                                        const std::vector<trainer::ga::TrainingSet>& sets, double a,
                                        int max_intervals = 2);

/// Constant-q IMM with `levels` noise levels q_j ∈ [1e-8 a², 10 a²] (the seed's a: [1e-10, 0.1]
/// (km/s²)²).
[[nodiscard]] Tuned<AxisCvImmSpec> tune_axis_cv_imm(
    const AxisCvImmSpec& base, const std::vector<trainer::ga::TrainingSet>& sets, double a,
    int levels = 3);

}  // namespace imm::evaluation
