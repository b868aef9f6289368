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
                               kSize = 3 * kEach;
  explicit ModeInnovations(double* buffer)
      : log_c(buffer), nu(buffer + kEach), s(buffer + 2 * kEach) {}
  double* log_c;
  double* nu;
  double* s;
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

/// step() of one kernel call's `lanes` lanes, stating its tracks' NIS where `nis` is not null (then
/// `nis` holds the step's `tracks` tracks, and the call's first lane is the x lane of track
/// `first_track`, which may be past the last: a bank's last block is padded): the step's family
/// records the predicted log c_j and the modes' innovations into `r`, then step_nis of each track
/// whose code is kOk, NaN for the others.
template <class Step>
void step_stating_nis(const CycleBlock& b, const ModeInnovations& r, int lanes,
                      std::size_t first_track, std::size_t tracks, const double* code, double* nis,
                      Step&& step);

/// The NIS of the track whose x lane is `lane` (its y lane the next) after a successful step, as
/// last_step_nis gives its one-track filter (a TwoAxisFilter of two ImmEstimator<2, 1>): per axis
/// ImmEstimator::collapse of the modes' ν_j and S_j with the normalized c_j, then νᵀ S⁻¹ ν with
/// S = diag(S_x, S_y). NaN where S is not positive definite.
inline double step_nis(const ModeInnovations& r, int n, int lane) {
  double nu[2], S[2];
  for (int axis = 0; axis < 2; ++axis) {
    auto at = [&](int j) { return j * ModeInnovations::kLanes + lane + axis; };
    double shift = -std::numeric_limits<double>::infinity();
    for (int j = 0; j < n; ++j) shift = std::max(shift, r.log_c[at(j)]);
    double scaled[kMaxModes], total = 0.0;
    for (int j = 0; j < n; ++j) {
      scaled[j] = std::exp(r.log_c[at(j)] - shift);
      total += scaled[j];
    }
    nu[axis] = 0.0;
    for (int j = 0; j < n; ++j) {
      const double c = scaled[j] / total;
      if (c != 0.0) nu[axis] += c * r.nu[at(j)];
    }
    S[axis] = 0.0;
    for (int j = 0; j < n; ++j) {
      const double c = scaled[j] / total;
      if (c == 0.0) continue;
      const double d = r.nu[at(j)] - nu[axis];
      S[axis] += c * (r.s[at(j)] + d * d);
    }
  }
  return diagonal_nis(nu[0], nu[1], S[0], S[1]);
}

/// One IMM cycle of family `family` over one block's W lanes (whole packs of Pack) of N modes from
/// lane `first`: `z` the lanes' plots (NaN for an unusable plot), `stepped` 1 for a lane to step;
/// `code` receives each lane's outcome.
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
}

template <class Step>
void step_stating_nis(const CycleBlock& b, const ModeInnovations& r, int lanes,
                      std::size_t first_track, std::size_t tracks, const double* code, double* nis,
                      Step&& step) {
  step();
  if (nis == nullptr) return;
  for (int l = 0; l < lanes && first_track + static_cast<std::size_t>(l / 2) < tracks; l += 2) {
    nis[first_track + static_cast<std::size_t>(l / 2)] =
        code[l] == kOk ? step_nis(r, b.modes, l) : std::numeric_limits<double>::quiet_NaN();
  }
}

}  // namespace imm::bank
