// SPDX-License-Identifier: Apache-2.0
#pragma once
// What the banks of two-mode IMMs in the 6-state space [x, vx, ax, y, vy, ay] share —
// WimmTrackBank (CV and Singer, polar plots) and FimmTrackBank (two CA modes, a learned sensor):
// a track is a lane; its modes' means and covariances' upper triangles, and log μ, are slots of
// the bank's structure of arrays. Per block of W tracks: the predicted mode probabilities, the
// mixing weights and the posterior μ (imm_algebra.hpp's, every family's, over the block's lanes
// as one pack), the mixing (ImmEstimator::mix) and the commit; each mode's prediction and update
// are the one-track mode's (filters/position_kalman_step.hpp). The other vector parts are loops
// over the lanes, with no branch and no call, which the compiler vectorizes (the mixing through
// imm_algebra.hpp's collapse on packs measured 3–4 % slower: docs/performance.md). What the
// modes' innovations answer (the NIS, the gate, the gating matrix) is two_mode_innovations.hpp's.
// Not installed.

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <span>

#include "axis_lane_bank.hpp"
#include "filters/position_kalman_step.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/estimation/gaussian_state.hpp"
#include "imm/estimation/imm_algebra.hpp"
#include "imm/estimation/step_status.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm/models/motion/motion_model.hpp"
#include "initial_state_check.hpp"

namespace imm::bank {

/// One block's step as a two-mode bank's kernel reads it: the block's first lane of slot 0 (the
/// slots `stride` apart), the plots' two components (NaN: unusable), 1 for a lane to step, the
/// lanes' codes to write, and where `nis` is not null its first `lanes` entries (the block's
/// tracks) to state.
struct BlockStep {
  double* state;
  std::ptrdiff_t stride;
  const double* z0;
  const double* z1;
  const double* stepped;
  double* code;
  double* nis;
  int lanes;
  /// Slot `entry` at the block's first lane.
  [[nodiscard]] double* slot(int entry) const { return state + entry * stride; }
};

/// One step of tracks 0 … plots.size() − 1 over blocks of kBlock tracks, one lane each, of a bank
/// whose slot 0 starts at `state`: per block the plots' two components (NaN for an unusable plot;
/// `pad` for a lane past the last track) and step flags, kernel(BlockStep) (`nis` null, or an
/// entry per track), then every track's status.
template <int kBlock, class Kernel>
void step_blocks(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status,
                 const Eigen::Vector2d& pad, double* state, std::ptrdiff_t stride, double* nis,
                 Kernel&& kernel) {
  const std::size_t n = plots.size();
  constexpr auto kLanes = static_cast<std::size_t>(kBlock);
  for (std::size_t first = 0; first < n; first += kLanes) {
    double z0[kBlock], z1[kBlock], stepped[kBlock], code[kBlock];
    for (std::size_t l = 0; l < kLanes; ++l) {
      const std::size_t track = first + l;
      const bool real = track < n;
      const bool usable = real && limits::usable_measurement(plots[track]);
      const double nan = std::numeric_limits<double>::quiet_NaN();
      z0[l] = usable ? plots[track](0) : (real ? nan : pad(0));
      z1[l] = usable ? plots[track](1) : (real ? nan : pad(1));
      stepped[l] = real ? 1.0 : 0.0;
    }
    kernel(BlockStep{state + first, stride, z0, z1, stepped, code,
                     nis == nullptr ? nullptr : nis + first,
                     static_cast<int>(std::min(kLanes, n - first))});
    for (std::size_t l = 0; l < kLanes && first + l < n; ++l) {
      status[first + l] = status_of(code[l]);
    }
  }
}

/// Where a mode's state sits in a track's slots: its d states per axis, its mean (2d slots) and
/// its covariance's upper triangle (d(2d + 1) slots).
struct ModeSlots {
  int d, mean, covariance;
};

/// The mixing of a block: the predicted mode probabilities (log c_j and c_j) and the mixing
/// weights μ_ij, from log μ in slots `log_mu` and `log_mu` + 1 under Π = p.
template <int W>
struct Mixing {
  double log_c[2][W], predicted[2][W], weight[2][2][W];  // weight[i][j]: μ_ij
};

/// Reads the block's modes into the mixing space (zero-padded where a mode has no acceleration)
/// and computes the mixing weights. `st(slot)` points at the block's first lane of a slot.
template <int W, class Slot>
[[gnu::always_inline]] inline void load_and_weigh(const double (&p)[2][2],
                                                  const std::array<ModeSlots, 2>& modes, int log_mu,
                                                  Slot&& st, Mixing<W>& mixing,
                                                  double (&embedded)[2][6][W],
                                                  double (&covariance)[2][6][6][W]) {
  // The predicted mode probabilities and the mixing weights (imm_algebra.hpp) over the block's
  // lanes as one pack. The bank's Π has no zero entry (checked where it is built), so no c̃_j
  // underflows and exact_prediction is never needed.
  using Pack = LanePackOf<W>;
  using Fn = algebra::LaneFunctions;
  const std::array<Pack, 2> log_mu_now{lane_load<Pack>(st(log_mu)),
                                       lane_load<Pack>(st(log_mu + 1))};
  // NOLINTNEXTLINE(cppcoreguidelines-pro-type-member-init): the two calls below fill them
  std::array<Pack, 2> scaled, predicted, log_c;
  Pack weights[4];  // weights[j · 2 + i]: μ_ij
  const Pack shift = algebra::scaled_probabilities<Fn>(2, log_mu_now, scaled);
  algebra::predict_probabilities<Fn, algebra::Division::kDivide>(
      2, [&p](int i, int j) { return p[i][j]; }, scaled, shift, predicted, log_c, weights);
  for (int j = 0; j < 2; ++j) {
    lane_store(mixing.log_c[j], log_c[j]);
    lane_store(mixing.predicted[j], Fn::exp(log_c[j]));
    for (int i = 0; i < 2; ++i) lane_store(mixing.weight[i][j], weights[j * 2 + i]);
  }
  for (int m = 0; m < 2; ++m) {
    const ModeSlots& mode = modes[static_cast<std::size_t>(m)];
    const int n = 2 * mode.d;
    for (int a = 0; a < 6; ++a) {
      const bool held = a % 3 < mode.d;
      const int i = (a / 3) * mode.d + a % 3;  // the mode's state, where it has one
      const double* mean = st(mode.mean + (held ? i : 0));
      IMM_LANES embedded[m][a][l] = held ? mean[l] : 0.0;
      for (int c = a; c < 6; ++c) {
        const int k = (c / 3) * mode.d + c % 3;
        const bool entry = held && c % 3 < mode.d;
        const double* value = st(mode.covariance + (entry ? packed(n, i, k) : 0));
        IMM_LANES covariance[m][a][c][l] = covariance[m][c][a][l] = entry ? value[l] : 0.0;
      }
    }
  }
}

/// Mode j's mixed initial condition (eq. 4–6 of seed 000, in the 6-state space) in its own
/// states, and its prediction x⁻ = F x, P⁻ = F P Fᵀ + Q, symmetrized (KalmanMode::propose).
template <int D, int W>
[[gnu::always_inline]] inline void mix_and_predict(const AxisModel& model, const double* weight0,
                                                   const double* weight1,
                                                   const double (&embedded)[2][6][W],
                                                   const double (&covariance)[2][6][6][W],
                                                   ModeLanes<D, W>& mode) {
  constexpr int N = 2 * D;
  double mean[N][W], d[2][N][W], mixed[N][N][W];
  for (int i = 0; i < N; ++i) {
    const int a = mixing_index(D, i);
    IMM_LANES {
      mean[i][l] = 0.0 + weight0[l] * embedded[0][a][l] + weight1[l] * embedded[1][a][l];
      d[0][i][l] = embedded[0][a][l] - mean[i][l];
      d[1][i][l] = embedded[1][a][l] - mean[i][l];
    }
  }
  // Σ_m w_m (P_m + d_m d_mᵀ), a weight of 0 adding nothing (ImmEstimator::moment_match); the
  // terms of (i, k) and (k, i) are the same products, so the result is exactly symmetric.
  for (int i = 0; i < N; ++i) {
    for (int k = i; k < N; ++k) {
      const int a = mixing_index(D, i), b = mixing_index(D, k);
      IMM_LANES {
        const double t0 = weight0[l] * (covariance[0][a][b][l] + d[0][i][l] * d[0][k][l]);
        const double t1 = weight1[l] * (covariance[1][a][b][l] + d[1][i][l] * d[1][k][l]);
        mixed[i][k][l] = mixed[k][i][l] =
            (0.0 + pick(weight0[l] != 0.0, t0, 0.0)) + pick(weight1[l] != 0.0, t1, 0.0);
      }
    }
  }
  predict<D, W>(model, mean, mixed, mode);
}

/// The first half of a block's cycle: the mixing (load_and_weigh) and both modes' mixed initial
/// conditions and predictions (mix_and_predict), mode 0 under `model0`, mode 1 under `model1`.
template <int D0, int D1, int W, class Slot>
[[gnu::always_inline]] inline void mix_and_predict_both(
    const double (&p)[2][2], const std::array<ModeSlots, 2>& modes, int log_mu, Slot&& st,
    const AxisModel& model0, const AxisModel& model1, Mixing<W>& mixing, ModeLanes<D0, W>& mode0,
    ModeLanes<D1, W>& mode1) {
  double embedded[2][6][W], covariance[2][6][6][W];
  load_and_weigh<W>(p, modes, log_mu, st, mixing, embedded, covariance);
  mix_and_predict<D0, W>(model0, mixing.weight[0][0], mixing.weight[1][0], embedded, covariance,
                         mode0);
  mix_and_predict<D1, W>(model1, mixing.weight[0][1], mixing.weight[1][1], embedded, covariance,
                         mode1);
}

/// The posterior μ of the two updated modes (ImmEstimator::finish_cycle), each track's outcome
/// code (kBadPlot where `usable` is 0; else the first mode's failure, the second's, or an
/// underflow) and whether it commits (`stepped` and kOk).
template <int D0, int D1, int W>
[[gnu::always_inline]] inline void finish(const Mixing<W>& mixing, const ModeLanes<D0, W>& mode0,
                                          const ModeLanes<D1, W>& mode1, const double* usable,
                                          const double* stepped, double (&log_mu)[2][W],
                                          double* code, double* commit) {
  // The posterior in log space (imm_algebra.hpp) over the block's lanes as one pack.
  using Pack = LanePackOf<W>;
  using Fn = algebra::LaneFunctions;
  std::array<Pack, 2> centered{
      lane_load<Pack>(mode0.log_likelihood) + lane_load<Pack>(mixing.log_c[0]),
      lane_load<Pack>(mode1.log_likelihood) + lane_load<Pack>(mixing.log_c[1])};
  // NOLINTNEXTLINE(cppcoreguidelines-pro-type-member-init): posterior fills them
  std::array<Pack, 2> scaled;
  Pack sum, log_sum;
  const Pack top = algebra::posterior<Fn>(2, centered, scaled, sum, log_sum);
  lane_store(log_mu[0], centered[0] - log_sum);
  lane_store(log_mu[1], centered[1] - log_sum);
  // The outcome: the first mode's failure, the second's, or an underflow.
  const Pack code0 = lane_load<Pack>(mode0.code), code1 = lane_load<Pack>(mode1.code);
  const Pack codes = lane_outcome(lane_load<Pack>(usable), pick(code0 != kOk, code0, code1), top);
  lane_store(code, codes);
  lane_store(commit, pick(lane_load<Pack>(stepped) != 0.0, pick(codes == kOk, 1.0, 0.0), 0.0));
}

/// Slot `slot` takes `value` in the lanes that commit.
template <int W, class Slot>
[[gnu::always_inline]] inline void keep(Slot&& st, int slot, const double* value,
                                        const double* commit) {
  double* target = st(slot);
  IMM_LANES target[l] = pick(commit[l] != 0.0, value[l], target[l]);
}

/// A mode's slots take its update in the lanes that commit.
template <int D, int W, class Slot>
[[gnu::always_inline]] inline void keep_mode(Slot&& st, const ModeSlots& slots,
                                             const ModeLanes<D, W>& mode, const double* commit) {
  constexpr int N = 2 * D;
  for (int i = 0; i < N; ++i) {
    keep<W>(st, slots.mean + i, mode.xu[i], commit);
    for (int k = i; k < N; ++k)
      keep<W>(st, slots.covariance + packed(N, i, k), mode.U[i][k], commit);
  }
}

/// Π as the kernels read it.
inline void transitions_into(const Eigen::Matrix2d& transition, double (&p)[2][2]) {
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < 2; ++j) p[i][j] = transition(i, j);
  }
}

/// Writes `state` (6 states) into a mode's slots of lane `lane`: its own components.
template <class Slot>
void start_mode(Slot&& slot, const ModeSlots& mode, std::ptrdiff_t lane,
                const GaussianState<6>& state) {
  const int n = 2 * mode.d;
  for (int i = 0; i < n; ++i) {
    slot(mode.mean + i)[lane] = state.mean(mixing_index(mode.d, i));
    for (int k = i; k < n; ++k) {
      slot(mode.covariance + packed(n, i, k))[lane] =
          state.covariance(mixing_index(mode.d, i), mixing_index(mode.d, k));
    }
  }
}

/// Starts lane `lane` (ImmEstimator::initialize): both modes take their components of `state`,
/// log μ (slots `log_mu`, `log_mu` + 1) the log of `initial`. InvalidParameter as
/// detail::check_initial_state (the one-track filters' check), before anything changes.
template <class Slot>
void start_track(Slot&& slot, const std::array<ModeSlots, 2>& modes, int log_mu,
                 std::ptrdiff_t lane, const GaussianState<6>& state,
                 const Eigen::Vector2d& initial) {
  detail::check_initial_state(state);
  for (const ModeSlots& mode : modes) start_mode(slot, mode, lane, state);
  for (int j = 0; j < 2; ++j) slot(log_mu + j)[lane] = safe_log(initial(j));
}

/// μ = exp(log μ) of lane `lane`.
template <class Slot>
ModeVector mode_probabilities(Slot&& slot, int log_mu, std::ptrdiff_t lane) {
  ModeVector mu(2);
  for (int j = 0; j < 2; ++j) mu(j) = std::exp(slot(log_mu + j)[lane]);
  return mu;
}

/// The combined estimate of lane `lane`: the modes embedded in the 6-state space (zero where a mode
/// has no acceleration; their covariances' upper triangles, all collapse reads), collapsed with
/// μ = exp(log μ) (imm_algebra.hpp; ImmEstimator::combine).
template <class Slot>
GaussianState<6> combined_estimate(Slot&& slot, const std::array<ModeSlots, 2>& modes, int log_mu,
                                   std::ptrdiff_t lane) {
  std::array<Vector<6>, 2> means{};
  std::array<SquareMatrix<6>, 2> covariances{};
  double mu[2];
  for (std::size_t m = 0; m < 2; ++m) {
    const ModeSlots& mode = modes[m];
    const int n = 2 * mode.d;
    means[m].setZero();
    covariances[m].setZero();
    for (int i = 0; i < n; ++i) {
      const int a = mixing_index(mode.d, i);
      means[m](a) = slot(mode.mean + i)[lane];
      for (int k = i; k < n; ++k) {
        const int c = mixing_index(mode.d, k);
        covariances[m](a, c) = slot(mode.covariance + packed(n, i, k))[lane];  // a ≤ c
      }
    }
    mu[m] = std::exp(slot(log_mu + static_cast<int>(m))[lane]);
  }
  GaussianState<6> out;
  algebra::collapse<6, double>(
      2, [&mu](int m) { return mu[m]; }, [&means](int m, int a) { return means[m](a); },
      [&covariances](int m, int a, int c) { return covariances[m](a, c); },
      [&out](int a) -> double& { return out.mean(a); },
      [&out](int a, int c) -> double& { return out.covariance(a, c); });
  out.covariance.triangularView<Eigen::StrictlyLower>() = out.covariance.transpose();
  return out;
}

}  // namespace imm::bank
