// SPDX-License-Identifier: Apache-2.0
#pragma once
// What the banks whose tracks are two axis lanes (x at an even lane, y after it) share —
// GaFuzzyTrackBank and InputEstimatorTrackBank: the outcome codes their kernels write, a track's
// code from its two lanes', the step over blocks of lanes, and a track's start and estimate in
// its lanes' slots. Not installed.

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <span>
#include <type_traits>
#include <utility>

#include "imm/core/physical_limits.hpp"
#include "imm/estimation/gaussian_state.hpp"
#include "imm/estimation/imm_algebra.hpp"
#include "imm/estimation/step_status.hpp"
#include "imm/math/lane_math.hpp"

namespace imm::bank {

/// Per-lane outcomes, in the order the one-track filters check them.
inline constexpr double kOk = 0.0, kBadPlot = 1.0, kSingular = 2.0, kNonFinite = 3.0,
                        kUnderflow = 4.0, kUndefined = 5.0;

/// A lane's code after the posterior (ImmEstimator's checks, in their order): kBadPlot where its
/// plot is unusable (`usable` 0), else the first failing mode's code (`mode_code`, kOk where none
/// failed), else kUnderflow where max_j ℓ_j + log c_j (`top`) is not finite (every likelihood
/// underflowed, or a NaN got through: top − top is 0 for a finite top only). S: a double or a pack.
template <class S>
[[nodiscard, gnu::always_inline]] inline S lane_outcome(const S& usable, const S& mode_code,
                                                        const S& top) {
  return pick(usable != 0.0,
              pick(mode_code != kOk, mode_code, pick(top - top == 0.0, kOk, kUnderflow)), kBadPlot);
}

/// Each track's code from its lanes' outcomes: that of the first axis that failed, or kBadPlot
/// where the step gave the lanes a NaN plot (an unusable one). Both lanes get it.
template <int W>
[[gnu::always_inline]] inline void track_codes(const double* outcome, const double* z,
                                               double* code) {
  for (int l = 0; l < W; l += 2) {
    const double track_outcome = outcome[l] != kOk ? outcome[l] : outcome[l + 1];
    code[l] = code[l + 1] = pick(z[l] == z[l] && z[l + 1] == z[l + 1], track_outcome, kBadPlot);
  }
}

/// The StepStatus of a code.
[[nodiscard]] inline StepStatus status_of(double code) {
  return code == kOk          ? StepStatus::kOk
         : code == kBadPlot   ? StepStatus::kInvalidMeasurement
         : code == kSingular  ? StepStatus::kSingularInnovation
         : code == kNonFinite ? StepStatus::kNonFiniteResult
         : code == kUndefined ? StepStatus::kUndefinedMeasurement
                              : StepStatus::kProbabilityUnderflow;
}

/// One step of tracks 0 … plots.size() − 1 over blocks of kBlock axis lanes. Per block: the
/// lanes' plots (NaN for an unusable plot, 0 for an empty lane) and step flags into `scratch`
/// (3 kBlock doubles), then kernel(std::integral_constant<int, W>{}, first, z, stepped, code)
/// once with W = kBlock (`wide`) or twice with W = kBlock / 2, first the block's first lane; then
/// every track's status from its code.
template <int kBlock, class Kernel>
void step_blocks(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status, bool wide,
                 double* scratch, Kernel&& kernel) {
  double* z = scratch;
  double* stepped = z + kBlock;
  double* code = stepped + kBlock;
  const std::size_t lanes = 2 * plots.size();
  constexpr auto kLanes = static_cast<std::size_t>(kBlock);
  for (std::size_t first = 0; first < lanes; first += kLanes) {
    for (std::size_t l = 0; l < kLanes; l += 2) {
      const std::size_t track = (first + l) / 2;
      const bool real = track < plots.size();
      const bool usable = real && limits::usable_measurement(plots[track]);
      const double nan = std::numeric_limits<double>::quiet_NaN();
      z[l] = usable ? plots[track].x() : (real ? nan : 0.0);
      z[l + 1] = usable ? plots[track].y() : (real ? nan : 0.0);
      stepped[l] = stepped[l + 1] = real ? 1.0 : 0.0;
    }
    if (wide) {
      kernel(std::integral_constant<int, kBlock>{}, first, z, stepped, code);
    } else {
      for (std::size_t half = 0; half < kLanes; half += kLanes / 2) {
        kernel(std::integral_constant<int, kBlock / 2>{}, first + half, z + half, stepped + half,
               code + half);
      }
    }
    for (std::size_t l = 0; l < kLanes && first + l < lanes; l += 2) {
      status[(first + l) / 2] = status_of(code[l]);
    }
  }
}

/// Σ_i w_i N(x_i, P_i) of n one-axis Gaussians [x0, x1, p00, p01, p11] (the first five entries of
/// mode(i)) collapsed to one (seed 000 eq. 4–5 and 10–11); a zero weight contributes nothing, as in
/// ImmEstimator.
template <class S, class Modes>
[[gnu::always_inline]] inline void collapse_axis(int n, const S* weight, Modes&& mode,
                                                 std::array<S, 5>& out) {
  // The covariance's entry (a, c), a ≤ c, at 2 + a + c.
  algebra::collapse<2, S>(
      n, [weight](int i) -> const S& { return weight[i]; },
      [&mode](int i, int a) -> const S& { return mode(i)[a]; },
      [&mode](int i, int a, int c) -> const S& { return mode(i)[2 + a + c]; },
      [&out](int a) -> S& { return out[a]; },
      [&out](int a, int c) -> S& { return out[2 + a + c]; });
}

/// One axis's innovations ν_j and variances S_j of n modes (nu(j), s(j)) collapsed with weights
/// c_j to their mixture's two moments (imm_algebra.hpp's collapse; ImmEstimator::collapse).
template <class S, class C, class Nu, class Variance>
[[gnu::always_inline]] inline void collapse_innovations(int n, const C& c, Nu&& nu, Variance&& s,
                                                        S& mean, S& variance) {
  algebra::collapse<1, S>(
      n, [&c](int j) { return S(c[j]); }, [&nu](int j, int /*a*/) { return S(nu(j)); },
      [&s](int j, int /*a*/, int /*b*/) { return S(s(j)); },
      [&mean](int /*a*/) -> S& { return mean; },
      [&variance](int /*a*/, int /*b*/) -> S& { return variance; });
}

/// xᵀ S⁻¹ x of the 2 × 2 S = [[s00, s01], [s01, s11]] written out, for a double or a pack of
/// lanes each; NaN unless S is positive definite (Sylvester: s00 > 0 and |S| > 0).
template <class S>
[[gnu::always_inline]] inline S quadratic_form_2x2(S s00, S s01, S s11, S x0, S x1) {
  const S det = s00 * s11 - s01 * s01;
  const S value = (s11 * (x0 * x0) - 2.0 * (s01 * (x0 * x1)) + s00 * (x1 * x1)) / det;
  return pick((s00 > 0.0) & (det > 0.0), value, splat<S>(std::numeric_limits<double>::quiet_NaN()));
}

/// νᵀ S⁻¹ ν with S = diag(s_x, s_y), as normalized_innovation_squared (track_filter.hpp) computes
/// it to the bit: S's Cholesky factor is L = diag(√s_x, √s_y) with an off-diagonal 0, solved
/// forward (L y = ν) and back (Lᵀ w = y), the zero's products kept (0 · ∞ is NaN there too), then
/// ν · w. NaN unless both variances are > 0.
inline double diagonal_nis(double nu_x, double nu_y, double s_x, double s_y) {
  if (!(s_x > 0.0 && s_y > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  const double root_x = std::sqrt(s_x), root_y = std::sqrt(s_y);
  constexpr double kOffDiagonal = 0.0;
  const double y_x = nu_x / root_x;
  const double y_y = (nu_y - kOffDiagonal * y_x) / root_y;
  const double w_y = y_y / root_y;
  const double w_x = (y_x - kOffDiagonal * w_y) / root_x;
  return nu_x * w_x + nu_y * w_y;
}

/// The normalized weights exp(v_j − max v) / Σ_k exp(v_k − max v) of n log-weights v into `out`,
/// with libm's exp: ImmEstimator::collapse's c_j from log c_j.
inline void normalized_weights(const double* log_weights, int n, double* out) {
  algebra::normalized<algebra::LibmFunctions, double>(
      n, [log_weights](int j) { return log_weights[j]; }, out);
}

/// A track's code in both its lanes (x at an even lane, y after it) from a pack of lane codes:
/// that of the first axis that failed.
template <class S, std::size_t... L>
[[gnu::always_inline]] inline S paired_codes(S code, std::index_sequence<L...> /*lanes*/) {
  const S x = __builtin_shufflevector(code, code, static_cast<int>(L & ~std::size_t{1})...);
  const S y = __builtin_shufflevector(code, code, static_cast<int>(L | 1U)...);
  return pick(x != kOk, x, y);
}
template <class S>
[[gnu::always_inline]] inline S paired_codes(S code) {
  return paired_codes(code, std::make_index_sequence<static_cast<std::size_t>(kLanesOf<S>)>{});
}

/// Axis `axis` (0: x, 1: y) of a [x, vx, y, vy] state: x0, x1, p00, p01, p11 (the cross-axis
/// covariance is not used, as by the one-track filters).
[[nodiscard]] inline std::array<double, 5> axis_entries(const GaussianState<4>& state, int axis) {
  const int a = 2 * axis;
  return {state.mean(a), state.mean(a + 1), state.covariance(a, a), state.covariance(a, a + 1),
          state.covariance(a + 1, a + 1)};
}

/// Track `track`'s [x, vx, y, vy] with a block-diagonal covariance: entry(e, lane) gives x0, x1,
/// p00, p01, p11 (e = 0 … 4) of axis lane `lane`.
template <class Entry>
[[nodiscard]] GaussianState<4> two_axis_estimate(std::ptrdiff_t track, Entry&& entry) {
  GaussianState<4> out;
  out.covariance.setZero();
  for (int axis = 0; axis < 2; ++axis) {
    const std::ptrdiff_t lane = 2 * track + axis;
    const int a = 2 * axis;
    out.mean(a) = entry(0, lane);
    out.mean(a + 1) = entry(1, lane);
    out.covariance(a, a) = entry(2, lane);
    out.covariance(a, a + 1) = out.covariance(a + 1, a) = entry(3, lane);
    out.covariance(a + 1, a + 1) = entry(4, lane);
  }
  return out;
}

}  // namespace imm::bank
