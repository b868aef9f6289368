// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The FCM-compensated CV mode's step of seed 003 (fcm_imm.hpp's derivation, steps 1, 4 and 7)
/// written once over a number type S: a double for one filter (FcmCompensatedMode), a pack of
/// lanes (lane_math.hpp) for many (FcmImmTrackBank), one axis filter per element. The clustering
/// of the errors sits between its two halves:
///   fcm_predict  the CV prediction from the mixed condition, S = p⁻₀₀ + R, the error
///                e = z − x̂⁻₀ (eq. 13) and the value the window takes (e / √S or e);
///   (the memberships u of that value, and c = λ (1 − u_noise))
///   fcm_update   the compensated gain K_c = K + c (ĝ − K), the Joseph-form update with it and
///                ℓ = log N(e; 0, S).
///
/// Every operation is that of predict() and update_with_gain() (kalman_filter.hpp) for
/// F = [[1, T], [0, 1]] and H = [1 0], whose other terms are exact products with 0 and 1, in
/// their order (the project compiles with -ffp-contract=off), and both instances use libm's √ and
/// log (a pack element by element): the clustering stops where its change first falls below a
/// tolerance, a rule a change in the last bit of an error can move by an iteration, so a bank keeps
/// the one-track filter's bits here.

#include <cmath>
#include <limits>
#include <type_traits>
#include <utility>

#include "imm/estimation/cv_axis_lanes.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"

namespace imm::lanes {

/// What one mode's step reads besides its state (fcm_mode_constants makes them of a spec). The
/// period, the plot variance and ĝ₁ come from the spec: unset, they are NaN, so a step from
/// constants never built from one gives NaN, not a filter of some default period.
struct FcmModeConstants {
  double T = std::numeric_limits<double>::quiet_NaN();  ///< sample period, s
  double R = std::numeric_limits<double>::quiet_NaN();  ///< σ_z²
  double q00 = 0.0;                                     ///< Q₀₀ of the mode's Q = q G Gᵀ
  double q01 = 0.0;                                     ///< Q₀₁
  double q10 = 0.0;   ///< Q₁₀ (q G Gᵀ rounds its two off-diagonal products apart)
  double q11 = 0.0;   ///< Q₁₁
  double gain = 0.0;  ///< λ, or 0 for an uncompensated mode
  double g_hat1 = std::numeric_limits<double>::quiet_NaN();  ///< ĝ₁ = 2/T of ĝ = [1, 2/T]ᵀ
  bool innovation_scale = true;  ///< the window takes e / √S (MembershipScale::kInnovation)
};

/// A usable-or-not flag of number type S: a bool, or a pack's mask.
template <class S>
using FcmFlag = decltype(std::declval<S>() > 0.0);

/// The first half of a mode's step (per element for a pack).
template <class S>
struct FcmPrediction {
  AxisEstimateOf<S> predicted;  ///< F x̂₀ and F P₀ Fᵀ + Q
  S s;                          ///< S = p⁻₀₀ + R
  S error;                      ///< e = z − x̂⁻₀
  S clustered;                  ///< what the window takes: e / √S or e
  FcmFlag<S> usable;            ///< 0 < S < ∞ (else the step is kSingularInnovation)
};

/// The second half (per element for a pack).
template <class S>
struct FcmUpdate {
  AxisEstimateOf<S> updated;  ///< x̂⁻ + K_c e and (I − K_c H) P⁻ (I − K_c H)ᵀ + K_c R K_cᵀ
  S log_likelihood;           ///< log N(e; 0, S)
  /// S usable and K_c finite (else kSingularInnovation): update_with_gain's factorization check.
  FcmFlag<S> factored;
  /// The estimate finite with no negative variance (else kNonFiniteResult), GaussianState::usable.
  FcmFlag<S> finite;
};

/// libm's log, element by element for a pack.
template <class S>
[[nodiscard, gnu::always_inline]] inline S libm_log(S x) {
  if constexpr (std::is_same_v<S, double>) {
    return std::log(x);
  } else {
    double lanes[kLanesOf<S>];
    lane_store(lanes, x);
    for (double& lane : lanes) lane = std::log(lane);
    return lane_load<S>(lanes);
  }
}

/// The CV prediction F x̂₀, F P₀ Fᵀ + Q from the mixed condition `mixed` (a missed plot's step).
template <class S>
[[nodiscard, gnu::always_inline]] inline AxisEstimateOf<S> fcm_prior(
    const FcmModeConstants& c, const AxisEstimateOf<S>& mixed) {
  AxisEstimateOf<S> predicted = cv_predict<S>(c.T, mixed);
  const S p01 = predicted.p01;  // F P Fᵀ is symmetric for a symmetric P; + Q, then symmetrized
  predicted.p00 = predicted.p00 + c.q00;
  predicted.p01 = 0.5 * ((p01 + c.q01) + (p01 + c.q10));
  predicted.p11 = predicted.p11 + c.q11;
  return predicted;
}

/// The first half from the mixed condition `mixed` with plot z (a usable plot).
template <class S>
[[nodiscard, gnu::always_inline]] inline FcmPrediction<S> fcm_predict(
    const FcmModeConstants& c, const AxisEstimateOf<S>& mixed, S z) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  FcmPrediction<S> out{};
  out.predicted = fcm_prior<S>(c, mixed);
  out.s = out.predicted.p00 + c.R;
  out.error = z - out.predicted.x0;
  out.clustered = c.innovation_scale ? out.error / lane_sqrt(out.s) : out.error;
  // 0 < S < ∞ as one comparison (lane_math.hpp says why not two joined by &).
  out.usable = pick(out.s > 0.0, out.s, kInf) < kInf;
  return out;
}

/// The compensation c = λ (1 − u_noise) of a mode whose memberships gave u_noise; exactly 0 for
/// an uncompensated mode (λ = 0), whatever u_noise.
template <class S>
[[nodiscard, gnu::always_inline]] inline S fcm_compensation(const FcmModeConstants& c, S u_noise) {
  return c.gain == 0.0 ? splat<S>(0.0) : c.gain * (1.0 - u_noise);
}

/// The second half with the compensation `compensation` (fcm_compensation).
template <class S>
[[nodiscard, gnu::always_inline]] inline FcmUpdate<S> fcm_update(const FcmModeConstants& c,
                                                                 const FcmPrediction<S>& p,
                                                                 S compensation) {
  const AxisEstimateOf<S>& q = p.predicted;
  const S k0 = q.p00 / p.s, k1 = q.p01 / p.s;
  const S g0 = k0 + compensation * (1.0 - k0), g1 = k1 + compensation * (c.g_hat1 - k1);
  // A = I − K_c H = [[1 − g0, 0], [−g1, 1]]; P = A P⁻ Aᵀ + K_c R K_cᵀ, its off-diagonal
  // symmetrized.
  const S a = 1.0 - g0, d = -g1;
  const S ap00 = a * q.p00, ap01 = a * q.p01;
  const S ap10 = d * q.p00 + q.p01, ap11 = d * q.p01 + q.p11;
  const S r0 = g0 * c.R, r1 = g1 * c.R;
  const S p01 = (ap00 * d + ap01) + r0 * g1;
  const S p10 = ap10 * a + r1 * g0;
  FcmUpdate<S> out{};
  out.updated = {q.x0 + g0 * p.error, q.x1 + g1 * p.error, ap00 * a + r0 * g0, 0.5 * (p01 + p10),
                 (ap10 * d + ap11) + r1 * g1};
  const S root = lane_sqrt(p.s);
  const S whitened = p.error / root;
  out.log_likelihood = -0.5 * (whitened * whitened + 2.0 * libm_log(root) + kLogTwoPi);
  // Finite as a sum of x·0 (0 for a finite x, NaN otherwise) compared once.
  out.factored = pick(p.usable, g0 * 0.0 + g1 * 0.0, 1.0) == 0.0;
  const AxisEstimateOf<S>& e = out.updated;
  const S zeros = e.x0 * 0.0 + e.x1 * 0.0 + e.p00 * 0.0 + e.p01 * 0.0 + e.p11 * 0.0;
  out.finite = zeros + pick(e.p00 >= 0.0, 0.0, 1.0) + pick(e.p11 >= 0.0, 0.0, 1.0) == 0.0;
  return out;
}

}  // namespace imm::lanes
