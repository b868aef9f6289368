// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Constant-velocity (CV) model: per axis [p, v], F = [[1, T], [0, 1]], input gain
/// G = [T²/2, T]ᵀ (seed 000 eq. 1, seed 004 eq. 14).

#include <cmath>

#include "imm/core/checks.hpp"
#include "imm/models/motion/motion_model.hpp"

namespace imm {

/// F of one CV axis [p, v] over a period T.
[[nodiscard]] inline SquareMatrix<2> cv_axis_transition(double T) {
  SquareMatrix<2> F;
  F << 1.0, T, 0.0, 1.0;
  return F;
}

/// G = [T²/2, T]ᵀ: how a constant acceleration over one period moves [p, v].
[[nodiscard]] inline Vector<2> cv_axis_input_gain(double T) { return Vector<2>(0.5 * T * T, T); }

/// Per-axis Q. Piecewise constant: q G Gᵀ = q [[T⁴/4, T³/2], [T³/2, T²]], q in (unit/s²)².
/// Continuous: q [[T³/3, T²/2], [T²/2, T]], q the acceleration PSD in unit²/s³.
[[nodiscard]] inline SquareMatrix<2> cv_axis_noise(double T, double q, NoiseForm form) {
  SquareMatrix<2> Q;
  if (form == NoiseForm::kPiecewiseConstant) {
    const Vector<2> g = cv_axis_input_gain(T);
    Q = q * g * g.transpose();
  } else {
    const double T2 = T * T;
    Q << T2 * T / 3.0, T2 / 2.0, T2 / 2.0, T;
    Q *= q;
  }
  return Q;
}

/// D-axis CV model, state [p₁, v₁, p₂, v₂, …].
template <int D>
[[nodiscard]] LinearMotionModel<2 * D> constant_velocity(
    double sample_period, double process_noise, NoiseForm form = NoiseForm::kPiecewiseConstant) {
  require_positive(sample_period, "sample_period");
  require_non_negative(process_noise, "process_noise");
  return per_axis_model<D>(cv_axis_transition(sample_period),
                           cv_axis_noise(sample_period, process_noise, form));
}

/// D-axis input gain of the CV model (one column per axis).
template <int D>
[[nodiscard]] Matrix<2 * D, D> cv_input_gain(double sample_period) {
  return block_input_gain<D>(cv_axis_input_gain(sample_period));
}

}  // namespace imm
