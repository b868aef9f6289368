// SPDX-License-Identifier: Apache-2.0
#pragma once
// One IMM cycle (imm_cycle.hpp) of a block of axis lanes — the banks whose track is two lanes of
// one axis each, x then y, a plot one number per lane: GaFuzzyTrackBank and FcmImmTrackBank. Not
// installed.

#include <array>
#include <cstddef>

#include "axis_lane_bank.hpp"
#include "imm/math/lane_math.hpp"
#include "imm_cycle.hpp"

namespace imm::bank {

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
};

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

}  // namespace imm::bank
