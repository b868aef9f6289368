// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// A per-axis IMM of constant-velocity KFs with constant process noises q_j (Q = q G Gᵀ), with
/// seed 000's transition and initial probabilities: the "three well-chosen noise levels" baseline
/// (IMM-tuned) against which the fuzzy tables' adaptation is judged.

#include <memory>
#include <vector>

#include "imm/filters/axis_filter.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// The IMM of CV Kalman filters per axis at fixed process-noise levels: the baseline the GA-fuzzy
/// IMM is compared with.
struct IMM_RUNTIME_EXPORT AxisCvImmSpec {
  /// Sample period, plot σ and mode switching of the axis IMM.
  AxisImmSettings settings;
  std::vector<double> process_noise = {1e-6, 1e-4, 1e-2};  ///< q_j ≥ 0, (unit/s²)²

  /// Throws InvalidParameter naming the field.
  void validate() const;
  /// Cartesian plots, two-point initialization (AxisImmSettings::track_options).
  [[nodiscard]] TrackOptions track_options(std::int64_t max_gap = kDefaultMaxGap) const {
    return settings.track_options(max_gap);
  }
};

/// The one-axis IMM of the spec (throws InvalidParameter naming the field).
[[nodiscard]] IMM_RUNTIME_EXPORT ImmEstimator<2, 1> build_axis_cv_imm(const AxisCvImmSpec& spec);
/// The two-axis filter of the spec: one build_axis_cv_imm per Cartesian axis.
[[nodiscard]] IMM_RUNTIME_EXPORT std::unique_ptr<TwoAxisFilter> make_axis_cv_imm_filter(
    const AxisCvImmSpec& spec);

}  // namespace imm
