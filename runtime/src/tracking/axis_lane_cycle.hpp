// SPDX-License-Identifier: Apache-2.0
#pragma once
// One IMM cycle (imm_cycle.hpp) of a block of axis lanes — the banks whose track is two lanes of
// one axis each, x then y, a plot one number per lane: GaFuzzyTrackBank and FcmImmTrackBank —
// and the NIS such a bank states for a step (step_nis). Not installed.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>

#include "axis_lane_bank.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm_cycle.hpp"

namespace imm::bank {

/// What a step that states its NIS keeps of one kernel call's lanes (at most kLanes), in a buffer
/// of kSize doubles the bank owns: per mode j and lane l, at j · kLanes + l, the predicted log c_j
/// of the step's mixing and the mode's ν_j and S_j of the update (the family records them).
struct ModeInnovations {
  static constexpr int kLanes = 16;
  static constexpr std::size_t kEach = static_cast<std::size_t>(kMaxModes) * kLanes,
                               kSize = 3 * kEach + std::size_t{2} * kLanes;
  explicit ModeInnovations(double* buffer)
      : log_c(buffer),
        nu(buffer + kEach),
        s(buffer + 2 * kEach),
        collapsed_nu(buffer + 3 * kEach),
        collapsed_s(buffer + 3 * kEach + kLanes) {}
  double* log_c;
  double* nu;
  double* s;
  // Per lane, the modes' ν_j and S_j collapsed with the normalized c_j (collapse_in_lanes).
  double* collapsed_nu;
  double* collapsed_s;
};

/// What the imm_cycle.hpp families of axis lanes share: a mode's estimate is its first five
/// entries [x0, x1, p00, p01, p11], mixed by collapse_axis, and a track's code is that of the first
/// of its two lanes that failed.
struct AxisLaneFamily {
  static constexpr int kCombined = 5;
  template <class S>
  using Estimate = std::array<S, kCombined>;

  // Σ_i w_i N(x_i, P_i) (seed 000 eq. 4–5 and 10–11).
  template <class S, class Modes>
  [[gnu::always_inline]] inline void mix(int n, const S* weight, Modes&& mode,
                                         Estimate<S>& out) const {
    collapse_axis(n, weight, mode, out);
  }

  // A track's code, in both its lanes.
  template <class S>
  [[gnu::always_inline]] inline S track_code(S code) const {
    return paired_codes(code);
  }

  // Where not null, the cycle of K packs (the call's lanes from its first) records the predicted
  // log c_j of its mixing (imm_cycle.hpp), and mode j's steps their ν_j and S_j: nu(k) and s(k)
  // of pack k.
  const ModeInnovations* record = nullptr;
  template <class S, int N, int K>
  [[gnu::always_inline]] inline void record_log_c(int n, const std::array<S, N> (&log_c)[K]) const {
    if (record == nullptr) return;
    for (int j = 0; j < n; ++j) {
      for (int k = 0; k < K; ++k) {
        lane_store(record->log_c + static_cast<std::ptrdiff_t>(j) * ModeInnovations::kLanes +
                       static_cast<std::ptrdiff_t>(k) * kLanesOf<S>,
                   log_c[k][j]);
      }
    }
  }
  template <class S, int K, class Nu, class Variance>
  [[gnu::always_inline]] inline void record_innovations(int j, Nu&& nu, Variance&& s) const {
    if (record == nullptr) return;
    for (int k = 0; k < K; ++k) {
      const std::ptrdiff_t at = static_cast<std::ptrdiff_t>(j) * ModeInnovations::kLanes +
                                static_cast<std::ptrdiff_t>(k) * kLanesOf<S>;
      lane_store(record->nu + at, S(nu(k)));
      lane_store(record->s + at, S(s(k)));
    }
  }
};

/// The NIS of the track whose x lane is `lane` (its y lane the next) after a successful step, as
/// last_step_nis gives its one-track filter (a TwoAxisFilter of two ImmEstimator<2, 1>): per axis
/// ImmEstimator::collapse of the modes' ν_j and S_j with the normalized c_j, then νᵀ S⁻¹ ν with
/// S = diag(S_x, S_y). NaN where S is not positive definite.
inline double step_nis(const ModeInnovations& r, int n, int lane) {
  double nu[2], S[2];
  for (int axis = 0; axis < 2; ++axis) {
    auto at = [&](int j) { return j * ModeInnovations::kLanes + lane + axis; };
    double c[kMaxModes];
    algebra::normalized<algebra::LibmFunctions, double>(
        n, [&](int j) { return r.log_c[at(j)]; }, c);
    collapse_innovations<double>(
        n, c, [&](int j) { return r.nu[at(j)]; }, [&](int j) { return r.s[at(j)]; }, nu[axis],
        S[axis]);
  }
  return diagonal_nis(nu[0], nu[1], S[0], S[1]);
}

/// Each lane's ν_j and S_j of the K packs from the call's first lane collapsed with the
/// normalized c_j into r.collapsed_nu and r.collapsed_s: step_nis' per-axis collapse in the packs'
/// lanes, c_j from lane_exp (for a family whose mode probabilities are not libm's).
template <class S, int N, int K>
[[gnu::always_inline]] inline void collapse_in_lanes(const ModeInnovations& r, int n) {
  constexpr int kPack = kLanesOf<S>;
  for (int k = 0; k < K; ++k) {
    const std::ptrdiff_t lane = static_cast<std::ptrdiff_t>(k) * kPack;
    auto at = [&](const double* v, int j) {
      return lane_load<S>(v + static_cast<std::ptrdiff_t>(j) * ModeInnovations::kLanes + lane);
    };
    std::array<S, N> c;  // NOLINT(cppcoreguidelines-pro-type-member-init): the n written
    algebra::normalized<algebra::LaneFunctions, S>(
        n, [&](int j) { return at(r.log_c, j); }, c);
    S nu, variance;
    collapse_innovations<S>(
        n, c, [&](int j) { return at(r.nu, j); }, [&](int j) { return at(r.s, j); }, nu, variance);
    lane_store(r.collapsed_nu + lane, nu);
    lane_store(r.collapsed_s + lane, variance);
  }
}

/// One IMM cycle of family `family` over one block's W lanes (whole packs of Pack) of N modes from
/// lane `first`: `z` the lanes' plots (NaN for an unusable plot), `stepped` 1 for a lane to step;
/// `code` receives each lane's outcome. Where the family records its innovations and its mode
/// probabilities are not libm's, each lane's collapse too (collapse_in_lanes).
template <class Pack, int W, int N, class F>
[[gnu::always_inline]] inline void axis_lane_cycle(const F& family, const CycleBlock& b,
                                                   std::ptrdiff_t first, const double* z,
                                                   const double* stepped, double* code) {
  constexpr int kPack = kLanesOf<Pack>, K = W / kPack;
  static_assert(K * kPack == W, "a block is whole packs");
  Pack plot[K], usable[K], step[K];
  for (int k = 0; k < K; ++k) {
    const std::ptrdiff_t offset = static_cast<std::ptrdiff_t>(k) * kPack;
    plot[k] = lane_load<Pack>(z + offset);
    usable[k] = pick(plot[k] == plot[k], 1.0, 0.0);
    step[k] = lane_load<Pack>(stepped + offset);
  }
  imm_cycle<Pack, N, K>(family, b, static_cast<int>(first), plot, usable, step, code);
  if constexpr (!kLibmProbabilities<F>) {
    if (family.record != nullptr) {
      collapse_in_lanes<Pack, N, K>(*family.record, N == kMaxModes ? b.modes : N);
    }
  }
}

/// step() of one kernel call's `lanes` lanes of family F, stating its tracks' NIS where `nis` is
/// not null (then `nis` holds the step's `tracks` tracks, and the call's first lane is the x lane
/// of track `first_track`, which may be past the last: a bank's last block is padded): the step's
/// family records the predicted log c_j and the modes' innovations into `r`; a family whose mode
/// probabilities are not libm's has collapsed each lane's already (axis_lane_cycle), so only
/// νᵀ S⁻¹ ν is left per track, the others take step_nis. NaN for a track whose code is not kOk.
template <class F, class Step>
void step_stating_nis(const CycleBlock& b, const ModeInnovations& r, int lanes,
                      std::size_t first_track, std::size_t tracks, const double* code, double* nis,
                      Step&& step) {
  step();
  if (nis == nullptr) return;
  for (int l = 0; l < lanes && first_track + static_cast<std::size_t>(l / 2) < tracks; l += 2) {
    double value = std::numeric_limits<double>::quiet_NaN();
    if (code[l] == kOk) {
      if constexpr (kLibmProbabilities<F>) {
        value = step_nis(r, b.modes, l);
      } else {
        value = diagonal_nis(r.collapsed_nu[l], r.collapsed_nu[l + 1], r.collapsed_s[l],
                             r.collapsed_s[l + 1]);
      }
    }
    nis[first_track + static_cast<std::size_t>(l / 2)] = value;
  }
}

}  // namespace imm::bank
