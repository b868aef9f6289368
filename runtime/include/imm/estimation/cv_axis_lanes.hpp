// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// One axis of a constant-velocity Kalman filter with a position plot, over a number type (a double
/// for one filter, a pack of lanes for many):
/// the prediction F x, F P Fᵀ with F = [[1, T], [0, 1]] and the Joseph-form update with
/// H = [1 0], as inline functions without branches. The operations and their order are those of
/// predict() and update_with_innovation() (kalman_filter.hpp) for these F and H, whose other terms
/// are exact products with 0 and 1. Used by the multi-track banks and the trainer's GA fitness
/// batch.

namespace imm::lanes {

/// A one-axis estimate [x0, x1], [[p00, p01], [p01, p11]] of number type S: a double, or a pack
/// of lanes (lane_math.hpp), one estimate per element.
template <class S>
struct AxisEstimateOf {
  S x0;   ///< position
  S x1;   ///< velocity
  S p00;  ///< position variance
  S p01;  ///< position-velocity covariance
  S p11;  ///< velocity variance
};
/// One estimate of doubles.
using AxisEstimate = AxisEstimateOf<double>;

/// F x and F P Fᵀ for F = [[1, T], [0, 1]] (no process noise yet).
template <class S>
[[gnu::always_inline]] inline AxisEstimateOf<S> cv_predict(double T, const AxisEstimateOf<S>& e) {
  const S fp00 = e.p00 + T * e.p01, fp01 = e.p01 + T * e.p11;
  return {e.x0 + T * e.x1, e.x1, fp00 + fp01 * T, fp01, e.p11};
}
/// cv_predict of doubles (for a braced estimate).
[[gnu::always_inline]] inline AxisEstimate cv_predict(double T, const AxisEstimate& e) {
  return cv_predict<double>(T, e);
}

/// The update of a predicted estimate by a position plot with residual r = z − x0 and variance R,
/// in the order of update_with_innovation: S = p00 + R, K = [p00, p01] / S, the Joseph form with
/// its off-diagonal symmetrized. `s` and `s_inverse` receive S and 1/S.
template <class S>
[[gnu::always_inline]] inline AxisEstimateOf<S> position_update(const AxisEstimateOf<S>& q,
                                                                double R, S residual, S& s,
                                                                S& s_inverse) {
  const S innovation_variance = q.p00 + R;
  s = innovation_variance;
  s_inverse = 1.0 / innovation_variance;
  const S k0 = q.p00 * s_inverse, k1 = q.p01 * s_inverse;
  const S C00 = q.p00 - k0 * q.p00, C01 = q.p01 - k0 * q.p01;
  const S C10 = q.p01 - k1 * q.p00, C11 = q.p11 - k1 * q.p01;
  const S kr0 = k0 * R, kr1 = k1 * R;
  const S u01 = C01 - C00 * k1 + kr0 * k1;
  const S u10 = C10 - C10 * k0 + kr1 * k0;
  return {q.x0 + k0 * residual, q.x1 + k1 * residual, C00 - C00 * k0 + kr0 * k0, 0.5 * (u01 + u10),
          C11 - C10 * k1 + kr1 * k1};
}
/// position_update of doubles (for a braced estimate).
[[gnu::always_inline]] inline AxisEstimate position_update(const AxisEstimate& q, double R,
                                                           double residual, double& s,
                                                           double& s_inverse) {
  return position_update<double>(q, R, residual, s, s_inverse);
}

}  // namespace imm::lanes
