// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// A linear-Gaussian motion model x(k+1) = F x(k) + w(k), w ~ N(0, Q), discretized once for a
/// fixed sample period. Models know nothing of filters: the filters are handed F and Q, and the
/// data-set generators draw w from the same Q to simulate truth.
///
/// State layout: one block per axis, [p, v] (CV) or [p, v, a] (CA, Singer); in 2-D
/// [x, vx, y, vy] or [x, vx, ax, y, vy, ay] (seed 004 eq. 14).

#include <cmath>
#include <stdexcept>
#include <string>

#include "imm/math/linear_algebra.hpp"

namespace imm {

/// A linear motion model x⁺ = F x + w, w ~ N(0, Q), over one period.
template <int N>
struct LinearMotionModel {
  /// The state dimension.
  static constexpr int kDim = N;
  SquareMatrix<N> transition = SquareMatrix<N>::Identity();  ///< F
  SquareMatrix<N> process_noise = SquareMatrix<N>::Zero();   ///< Q
};

/// How the process noise of a kinematic (CV, CA) model is discretized.
enum class NoiseForm {
  /// Piecewise-constant white noise: the highest derivative receives a new independent value
  /// every period, Q = q G Gᵀ with q the variance of that value (seed 000 eq. 1, seed 001,
  /// seed 004 eq. 17). The seeds' form and the default.
  kPiecewiseConstant,
  /// Exact discretization of continuous white noise of power spectral density q.
  kContinuous,
};

/// What a mode's motion is made from besides the interval: a filter fed time stamps remakes its
/// F and Q for each interval from these (filters/plain_imm.cpp fills them for CV, CA, Singer and CT
/// modes). Over an interval Δt the piecewise-constant form draws one value of the highest
/// derivative per interval (q its variance, whatever Δt); the continuous form integrates q over Δt.
struct MotionParameters {
  double process_noise = 0.0;                      ///< q (CV, CA, CT's linear acceleration)
  NoiseForm form = NoiseForm::kPiecewiseConstant;  ///< how q enters Q
  double tau = 0.0;                                ///< Singer τ, s
  double sigma = 0.0;                              ///< Singer σ_a
  double turn_noise = 0.0;                         ///< CT: the turn rate's noise
};

/// Makes a mode's motion `Motion` (a LinearMotionModel, a ScheduledNoiseMode's step) over any
/// interval; empty (no `make`) for a mode built for one sample period only.
template <class Motion>
struct MotionMaker {
  /// The motion over an interval (s) from the parameters; none: the mode has one period only.
  Motion (*make)(double interval, const MotionParameters& parameters) = nullptr;
  /// What `make` reads besides the interval.
  MotionParameters parameters;
  /// Whether there is a `make`.
  [[nodiscard]] explicit operator bool() const { return make != nullptr; }
  /// The motion over `interval` s.
  [[nodiscard]] Motion operator()(double interval) const { return make(interval, parameters); }
};

/// Places `block` D times on the diagonal: the per-axis model becomes a D-axis model.
template <int D, int K>
[[nodiscard]] SquareMatrix<D * K> block_diagonal(const SquareMatrix<K>& block) {
  SquareMatrix<D* K> result = SquareMatrix<D * K>::Zero();
  for (int axis = 0; axis < D; ++axis) result.template block<K, K>(axis * K, axis * K) = block;
  return result;
}

/// Stacks a per-axis input gain g (K×1) into the D-axis gain (DK×D), one column per axis.
template <int D, int K>
[[nodiscard]] Matrix<D * K, D> block_input_gain(const Vector<K>& gain) {
  Matrix<D * K, D> result = Matrix<D * K, D>::Zero();
  for (int axis = 0; axis < D; ++axis) result.template block<K, 1>(axis * K, axis) = gain;
  return result;
}

/// The D-axis model whose every axis has transition `axis_F` and noise `axis_Q`.
template <int D, int K>
[[nodiscard]] LinearMotionModel<D * K> per_axis_model(const SquareMatrix<K>& axis_F,
                                                      const SquareMatrix<K>& axis_Q) {
  LinearMotionModel<D * K> model;
  model.transition = block_diagonal<D>(axis_F);
  model.process_noise = block_diagonal<D>(axis_Q);
  return model;
}

}  // namespace imm
