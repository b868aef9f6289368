// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Constant-acceleration (CA) model: per axis [p, v, a],
/// F = [[1, T, T²/2], [0, 1, T], [0, 0, 1]] (seed 002 eq. 8).

#include "imm/core/checks.hpp"
#include "imm/models/motion/motion_model.hpp"

namespace imm {

/// F of one CA axis [p, v, a] over a period T.
[[nodiscard]] inline SquareMatrix<3> ca_axis_transition(double T) {
  SquareMatrix<3> F;
  F << 1.0, T, 0.5 * T * T, 0.0, 1.0, T, 0.0, 0.0, 1.0;
  return F;
}

/// Per-axis Q. Piecewise constant (Wiener-process acceleration): q G Gᵀ with G = [T²/2, T, 1]ᵀ,
/// q the variance of the acceleration increment per period. Continuous: exact discretization of
/// white jerk of PSD q, q [[T⁵/20, T⁴/8, T³/6], [T⁴/8, T³/3, T²/2], [T³/6, T²/2, T]].
[[nodiscard]] inline SquareMatrix<3> ca_axis_noise(double T, double q, NoiseForm form) {
  SquareMatrix<3> Q;
  if (form == NoiseForm::kPiecewiseConstant) {
    const Vector<3> g(0.5 * T * T, T, 1.0);
    Q = q * g * g.transpose();
  } else {
    const double T2 = T * T, T3 = T2 * T, T4 = T3 * T, T5 = T4 * T;
    Q << T5 / 20.0, T4 / 8.0, T3 / 6.0,  //
        T4 / 8.0, T3 / 3.0, T2 / 2.0,    //
        T3 / 6.0, T2 / 2.0, T;
    Q *= q;
  }
  return Q;
}

/// D-axis CA model, state [p₁, v₁, a₁, p₂, v₂, a₂, …].
template <int D>
[[nodiscard]] LinearMotionModel<3 * D> constant_acceleration(
    double sample_period, double process_noise, NoiseForm form = NoiseForm::kPiecewiseConstant) {
  require_positive(sample_period, "sample_period");
  require_non_negative(process_noise, "process_noise");
  return per_axis_model<D>(ca_axis_transition(sample_period),
                           ca_axis_noise(sample_period, process_noise, form));
}

}  // namespace imm
