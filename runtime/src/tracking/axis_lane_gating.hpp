// SPDX-License-Identifier: Apache-2.0
#pragma once
// The gating question of a bank of axis lanes (axis_lane_cycle.hpp) whose modes' predictions read
// the plot, the GA-fuzzy IMM's and the FCM-IMM's: for a track and a candidate plot, the answers of
// its one-track filter after predict() (TwoAxisFilter over two ImmEstimator<2, 1> that score
// candidates by trial updates). Per axis:
//   log-likelihood  log Σ_j c_j N_j, each N_j a trial step of mode j (the family's step) from its
//                   mixed condition, nothing written (ImmEstimator::candidate_log_likelihood);
//   distance        ν²/S under the prediction without a plot, each mode's (the family's
//                   predicted_plot) collapsed with the normalized c_j once per track
//                   (ImmEstimator::candidate_distance, to rounding);
// a track's answer is the sum over its two axes. A track's x and y lanes go through the cycle's
// mixing (mix_modes) and the family's steps together, as one pack of two: the bank's own
// arithmetic, which its step() repeats for the plot chosen; the few remaining sums are the
// one-track filter's, with libm's exponentials and logarithms. The mixing is made once per track;
// a trial is stepped only for a pair inside the gate. Not installed.
//
// A family provides, besides what imm_cycle.hpp reads:
//   predicted_plot(j, mixed, z_hat, variance)   mode j's prediction without a plot from its mixed
//                                               condition (doubles): ẑ_j and S_j = P⁻₀₀ + R

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "imm/core/physical_limits.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/math/linear_algebra.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm_cycle.hpp"

namespace imm::bank {

/// A track's two axis lanes, x then y.
using TrackPack = LanePackOf<2>;

/// One track held for candidate plots: its mixing (N ≥ the mode count; the loops run to `modes`),
/// per axis log c_j and the modes' predictions without a plot collapsed: ẑ = Σ_j c_j ẑ_j and
/// S = Σ_j c_j (S_j + (ẑ_j − ẑ)²) with c_j normalized, ẑ NaN where a mode did not predict.
/// hold_track fills it (the mixing as the cycle's: mix_modes writes what it reads).
template <class F, int N>
// NOLINTNEXTLINE(cppcoreguidelines-pro-type-member-init): hold_track fills the mixing
struct HeldTrack {
  CycleMixing<TrackPack, N, 1, F> mixing;
  int modes = 0;
  double log_c[2][N] = {};
  double collapsed[2] = {}, collapsed_variance[2] = {};
};

/// Holds track `track` of block `b` (its lanes 2 track and 2 track + 1) for candidates; the state
/// is not changed.
template <int N, class F>
void hold_track(const F& family, const CycleBlock& b, int track, HeldTrack<F, N>& h) {
  h.modes = N == kMaxModes ? b.modes : N;
  const TrackPack active[1] = {splat<TrackPack>(1.0)};
  mix_modes<TrackPack, N, 1>(family, b, 2 * track, active, h.mixing);
  for (int j = 0; j < h.modes; ++j) {
    const Lanes<TrackPack> log_c = lanes_of(h.mixing.log_c[0][j]);
    for (int axis = 0; axis < 2; ++axis) h.log_c[axis][j] = log_c[static_cast<std::size_t>(axis)];
  }
  for (int axis = 0; axis < 2; ++axis) {
    double c[N], z_hat[N], variance[N];
    normalized_weights(h.log_c[axis], h.modes, c);
    bool predicted = true;
    for (int j = 0; j < h.modes; ++j) {
      typename F::template Estimate<double> mixed;
      for (std::size_t e = 0; e < mixed.size(); ++e)
        mixed[e] = lanes_of(h.mixing.mixed[j][0][e])[static_cast<std::size_t>(axis)];
      family.predicted_plot(j, mixed, z_hat[j], variance[j]);
      predicted = predicted && std::isfinite(z_hat[j]) && std::isfinite(variance[j]);
    }
    double mean = 0.0, S = 0.0;
    collapse_innovations<double>(
        h.modes, c, [&z_hat](int j) { return z_hat[j]; },
        [&variance](int j) { return variance[j]; }, mean, S);
    h.collapsed[axis] = predicted ? mean : std::numeric_limits<double>::quiet_NaN();
    h.collapsed_variance[axis] = S;
  }
}

/// The squared distance of plot z to the held track's collapsed prediction without a plot, the
/// sum of the axes' ν²/S with ν = z − ẑ (ImmEstimator::collapse's Σ_j c_j (z − ẑ_j) and
/// Σ_j c_j (S_j + (ν_j − ν)²), the same to rounding: the c_j sum to 1); NaN where a mode did not
/// predict or an S is not positive.
template <class F, int N>
double track_distance(const HeldTrack<F, N>& h, const Eigen::Vector2d& z) {
  double distance = 0.0;
  for (int axis = 0; axis < 2; ++axis) {
    const double nu = z(axis) - h.collapsed[axis], S = h.collapsed_variance[axis];
    if (!(S > 0.0)) return std::numeric_limits<double>::quiet_NaN();
    distance += nu * nu / S;
  }
  return distance;
}

/// The log-likelihood of plot z under the held track: per axis log Σ_j c_j N_j of a trial step
/// of every mode (both axes in one pack), summed; NaN where a mode refuses the plot.
template <class F, int N>
double track_log_likelihood(const F& family, const HeldTrack<F, N>& h, const Eigen::Vector2d& z) {
  ModeVector terms[2] = {ModeVector(h.modes), ModeVector(h.modes)};
  const TrackPack plot[1] = {lane_load<TrackPack>(z.data())};
  for (int j = 0; j < h.modes; ++j) {
    std::array<TrackPack, F::kEntries> updated[1];
    TrackPack log_likelihood[1], code[1];
    family.template steps<TrackPack, 1>(j, h.mixing.mixed[j], h.mixing.modes[j], plot, updated,
                                        log_likelihood, code);
    const Lanes<TrackPack> ell = lanes_of(log_likelihood[0]), codes = lanes_of(code[0]);
    for (int axis = 0; axis < 2; ++axis) {
      const auto a = static_cast<std::size_t>(axis);
      if (codes[a] != kOk) return std::numeric_limits<double>::quiet_NaN();
      terms[axis](j) = ell[a] + h.log_c[axis][j];
    }
  }
  return log_sum_exp(terms[0]) + log_sum_exp(terms[1]);
}

/// The gating matrix of a bank's call (TrackBankCalls::LaneScore: tracks 0 … out.rows() − 1 of
/// block `b`, the state at its first lane, against its plots): each track held in turn with
/// family_of(t), the family of track t (a family may point at its track's own slots), then every
/// plot scored (see the file comment): NaN for an unusable plot, −∞ past the track's gate
/// (call.gate_of(t)), else the log-likelihood. The state is not changed.
template <int N, class F, class FamilyOf, class Call>
void score_tracks(const CycleBlock& b, FamilyOf&& family_of, const Call& call) {
  HeldTrack<F, N> held;
  for (Eigen::Index t = 0; t < call.out.rows(); ++t) {
    const F family = family_of(t);
    const double track_gate = call.gate_of(static_cast<std::size_t>(t));
    hold_track<N>(family, b, static_cast<int>(t), held);
    for (std::size_t q = 0; q < call.plots.size(); ++q) {
      const Eigen::Vector2d& z = call.plots[q];
      double& entry = call.out(t, static_cast<Eigen::Index>(q));
      if (!limits::usable_measurement(z)) {
        entry = std::numeric_limits<double>::quiet_NaN();
      } else if (track_distance(held, z) > track_gate) {
        entry = -std::numeric_limits<double>::infinity();
      } else {
        entry = track_log_likelihood(family, held, z);
      }
    }
  }
}

}  // namespace imm::bank
