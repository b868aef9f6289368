// SPDX-License-Identifier: Apache-2.0
#pragma once
/// A per-axis IMM of constant-velocity KFs with constant process noises q_j (Q = q G Gᵀ), with
/// seed 000's transition and initial probabilities: the "three well-chosen noise levels" baseline
/// (IMM-tuned) against which the fuzzy tables' adaptation is judged.

#include <memory>
#include <vector>

#include "imm/filters/axis_filter.hpp"

namespace imm {

struct AxisCvImmSpec {
  AxisImmSettings settings;
  std::vector<double> process_noise = {1e-6, 1e-4, 1e-2};  ///< q_j ≥ 0, (unit/s²)²

  void validate() const;
  /// Cartesian plots, two-point initialization (AxisImmSettings::track_options).
  [[nodiscard]] TrackOptions track_options(std::int64_t max_gap = kDefaultMaxGap) const {
    return settings.track_options(max_gap);
  }
};

[[nodiscard]] ImmEstimator<2, 1> build_axis_cv_imm(const AxisCvImmSpec& spec);
[[nodiscard]] std::unique_ptr<TwoAxisFilter> make_axis_cv_imm_filter(const AxisCvImmSpec& spec);

}  // namespace imm
