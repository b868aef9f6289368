// SPDX-License-Identifier: Apache-2.0
#pragma once
// What the banks of two-mode IMMs in the 6-state space [x, vx, ax, y, vy, ay] share —
// WimmTrackBank (CV and Singer, polar plots) and FimmTrackBank (two CA modes, a learned sensor):
// a track is a lane; its modes' means and covariances' upper triangles, and log μ, are slots of
// the bank's structure of arrays. Per block of W tracks: the predicted mode probabilities and
// the mixing (ImmEstimator::predict_mode_probabilities and mix), the posterior μ
// (ImmEstimator::finish_cycle) and the commit; each mode's prediction and update are the
// one-track mode's (filters/position_kalman_step.hpp). Every statement of the vector parts is a
// loop over the lanes, with no branch and no call, which the compiler vectorizes. Not installed.

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <span>

#include "axis_lane_bank.hpp"
#include "filters/position_kalman_step.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/estimation/gaussian_state.hpp"
#include "imm/estimation/step_status.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm/models/motion/motion_model.hpp"

namespace imm::bank {

/// One step of tracks 0 … plots.size() − 1 over blocks of kBlock tracks, one lane each. Per block:
/// the plots' two components (NaN for an unusable plot; `pad` for a lane past the last track)
/// and step flags, kernel(first, z0, z1, stepped, code), then every track's status.
template <int kBlock, class Kernel>
void step_blocks(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status,
                 const Eigen::Vector2d& pad, Kernel&& kernel) {
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
    kernel(first, z0, z1, stepped, code);
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
  const double* log_mu0 = st(log_mu);
  const double* log_mu1 = st(log_mu + 1);
  IMM_LANES {
    const double a = log_mu0[l], c = log_mu1[l];
    const double shift = pick(c > a, c, a);
    const double scaled0 = lane_exp(a - shift), scaled1 = lane_exp(c - shift);
    const double sum0 = 0.0 + p[0][0] * scaled0 + p[1][0] * scaled1;
    const double sum1 = 0.0 + p[0][1] * scaled0 + p[1][1] * scaled1;
    mixing.log_c[0][l] = lane_log(sum0) + shift;
    mixing.log_c[1][l] = lane_log(sum1) + shift;
    mixing.predicted[0][l] = lane_exp(mixing.log_c[0][l]);
    mixing.predicted[1][l] = lane_exp(mixing.log_c[1][l]);
    mixing.weight[0][0][l] = p[0][0] * scaled0 / sum0;
    mixing.weight[1][0][l] = p[1][0] * scaled1 / sum0;
    mixing.weight[0][1][l] = p[0][1] * scaled0 / sum1;
    mixing.weight[1][1][l] = p[1][1] * scaled1 / sum1;
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
  IMM_LANES {
    const double posterior0 = mode0.log_likelihood[l] + mixing.log_c[0][l];
    const double posterior1 = mode1.log_likelihood[l] + mixing.log_c[1][l];
    const double shift = pick(posterior1 > posterior0, posterior1, posterior0);
    const double sum = 0.0 + lane_exp(posterior0 - shift) + lane_exp(posterior1 - shift);
    const double log_sum = lane_log(sum);
    log_mu[0][l] = (posterior0 - shift) - log_sum;
    log_mu[1][l] = (posterior1 - shift) - log_sum;
    const double mode_code = pick(mode0.code[l] != kOk, mode0.code[l], mode1.code[l]);
    const double outcome =
        pick(mode_code != kOk, mode_code, pick(std::isfinite(shift), kOk, kUnderflow));
    code[l] = pick(usable[l] != 0.0, outcome, kBadPlot);
    commit[l] = pick((stepped[l] != 0.0) & (code[l] == kOk), 1.0, 0.0);
  }
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
/// log μ (slots `log_mu`, `log_mu` + 1) the log of `initial`. InvalidParameter("state") for a
/// state that is not finite.
template <class Slot>
void start_track(Slot&& slot, const std::array<ModeSlots, 2>& modes, int log_mu,
                 std::ptrdiff_t lane, const GaussianState<6>& state,
                 const Eigen::Vector2d& initial) {
  if (!state.all_finite()) throw InvalidParameter("state", "must be finite");
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

/// The combined estimate of lane `lane`: the modes embedded in the 6-state space, moment-matched
/// with μ = exp(log μ) (ImmEstimator::combine).
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
        covariances[m](a, c) = covariances[m](c, a) = slot(mode.covariance + packed(n, i, k))[lane];
      }
    }
    mu[m] = std::exp(slot(log_mu + static_cast<int>(m))[lane]);
  }
  GaussianState<6> out;
  out.mean = mu[0] * means[0] + mu[1] * means[1];
  out.covariance.setZero();
  for (std::size_t m = 0; m < 2; ++m) {
    if (mu[m] == 0.0) continue;
    const Vector<6> d = means[m] - out.mean;
    out.covariance += mu[m] * (covariances[m] + d * d.transpose());
  }
  return out;
}

/// One block's share of a gating matrix: its first `lanes` tracks against `plots`, column q of the
/// block's rows at out + q · out_stride.
struct GatingBlock {
  std::span<const Eigen::Vector2d> plots;
  double gate = 0.0;
  double* out = nullptr;
  std::ptrdiff_t out_stride = 0;
  int lanes = 0;
  const double* gate_scale = nullptr;  // per lane from the block's first, or null: every factor 1

  /// Lane l's gate: gate × gate_scale[l].
  [[nodiscard]] double gate_of(int l) const {
    return gate_scale == nullptr ? gate : gate * gate_scale[l];
  }
};

/// The gating matrix `out` of `plots` in blocks of kBlock tracks: score(first, block) per block;
/// gate_scale: a factor per track, or null.
template <int kBlock, class Score>
void score_in_blocks(std::span<const Eigen::Vector2d> plots, double gate, const double* gate_scale,
                     Eigen::Ref<Eigen::MatrixXd> out, Score&& score) {
  for (Eigen::Index first = 0; first < out.rows(); first += kBlock) {
    const GatingBlock block{plots,
                            gate,
                            out.data() + first,
                            out.outerStride(),
                            static_cast<int>(std::min<Eigen::Index>(kBlock, out.rows() - first)),
                            gate_scale == nullptr ? nullptr : gate_scale + first};
    score(static_cast<std::ptrdiff_t>(first), block);
  }
}

/// The normalized predicted mode probabilities c_j of a block's lanes (ImmEstimator::collapse's
/// weights: exp(log c_j − max) over their sum), which a candidate's collapse reads.
template <int W>
void normalized_predicted(const Mixing<W>& mixing, double (&c)[2][W]) {
  for (int l = 0; l < W; ++l) {
    const double log_c[2] = {mixing.log_c[0][l], mixing.log_c[1][l]};
    double lane[2];
    normalized_weights(log_c, 2, lane);
    for (int j = 0; j < 2; ++j) c[j][l] = lane[j];
  }
}

/// νᵀ S⁻¹ ν of two modes' innovations ν_j and S_j collapsed with weights c_j: ν = Σ_j c_j ν_j and
/// S = Σ_j c_j (S_j + (ν_j − ν)(ν_j − ν)ᵀ) (ImmEstimator::collapse); NaN where S is not positive
/// definite.
inline double collapsed_distance(const double (&c)[2], const Eigen::Vector2d (&nu)[2],
                                 const Eigen::Matrix2d (&Sj)[2]) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  Eigen::Matrix2d S = Eigen::Matrix2d::Zero();
  for (int j = 0; j < 2; ++j) {
    if (c[j] != 0.0) mean += c[j] * nu[j];
  }
  for (int j = 0; j < 2; ++j) {
    if (c[j] == 0.0) continue;
    const Eigen::Vector2d d = nu[j] - mean;
    S += c[j] * (Sj[j] + d * d.transpose());
  }
  return quadratic_form_2x2(S(0, 0), S(0, 1), S(1, 1), mean(0), mean(1));
}

/// Lane l's ν_j and S_j of the modes' arrays.
template <int W>
void lane_innovations(const double* const (&nu)[2][2], const double* const (&s)[2][3], int l,
                      Eigen::Vector2d (&nu_l)[2], Eigen::Matrix2d (&s_l)[2]) {
  for (int j = 0; j < 2; ++j) {
    nu_l[j] = Eigen::Vector2d(nu[j][0][l], nu[j][1][l]);
    s_l[j] << s[j][0][l], s[j][1][l], s[j][1][l], s[j][2][l];
  }
}

/// The squared distance of lane l's candidate to the collapsed predicted plot, from the modes'
/// innovations ν_j (nu[j][0 or 1]) and S_j (s[j][0 … 2]) and c (normalized_predicted).
template <int W>
double collapsed_distance(const double (&c)[2][W], const double* const (&nu)[2][2],
                          const double* const (&s)[2][3], int l) {
  Eigen::Vector2d nu_l[2];
  Eigen::Matrix2d s_l[2];
  lane_innovations<W>(nu, s, l, nu_l, s_l);
  return collapsed_distance({c[0][l], c[1][l]}, nu_l, s_l);
}

/// The NIS each of a block's first `lanes` lanes states after its step (nis[l], NaN where code[l]
/// is not kOk): what last_step_nis gives the one-track filter, ImmEstimator::innovation of the
/// modes' ν_j and S_j of the update — each first rewritten by to_plot(l, ν_j, S_j) into the
/// plot's measurement where the filter reports another's (the wIMM's fused azimuth) — collapsed
/// with the predicted c_j.
template <int D0, int D1, int W, class ToPlot>
void step_nis(const Mixing<W>& mixing, const ModeLanes<D0, W>& mode0, const ModeLanes<D1, W>& mode1,
              const double* code, int lanes, ToPlot&& to_plot, double* nis) {
  double c[2][W];
  normalized_predicted<W>(mixing, c);
  const double* const nu[2][2] = {{mode0.nu[0], mode0.nu[1]}, {mode1.nu[0], mode1.nu[1]}};
  const double* const s[2][3] = {{mode0.s[0], mode0.s[1], mode0.s[2]},
                                 {mode1.s[0], mode1.s[1], mode1.s[2]}};
  for (int l = 0; l < lanes; ++l) {
    if (code[l] != kOk) {
      nis[l] = std::numeric_limits<double>::quiet_NaN();
      continue;
    }
    Eigen::Vector2d nu_l[2];
    Eigen::Matrix2d s_l[2];
    lane_innovations<W>(nu, s, l, nu_l, s_l);
    for (int j = 0; j < 2; ++j) to_plot(l, nu_l[j], s_l[j]);
    nis[l] = collapsed_distance({c[0][l], c[1][l]}, nu_l, s_l);
  }
}

/// Whether a block's first g.lanes lanes all lie outside their gates for one candidate plot, from
/// the two modes' linearizations at their predictions and S_j = H P⁻ Hᵀ + R (update_mode's), before
/// any update: then no lane needs one. A lane whose h is undefined there or whose S is not
/// positive definite counts as inside (the update decides its answer).
template <int D0, int D1, int W>
bool all_outside_the_gate(const double (&c)[2][W], const Linearization<W>& lin0,
                          const ModeLanes<D0, W>& mode0, const Linearization<W>& lin1,
                          const ModeLanes<D1, W>& mode1, const GatingBlock& g) {
  double pht0[2 * D0][2][W], pht1[2 * D1][2][W], s0[3][W], s1[3][W];
  innovation_covariance<D0, W>(lin0, mode0.P, pht0, s0);
  innovation_covariance<D1, W>(lin1, mode1.P, pht1, s1);
  const double* const nu[2][2] = {{lin0.nu0, lin0.nu1}, {lin1.nu0, lin1.nu1}};
  const double* const s[2][3] = {{s0[0], s0[1], s0[2]}, {s1[0], s1[1], s1[2]}};
  for (int l = 0; l < g.lanes; ++l) {
    if (lin0.defined[l] == 0.0 || lin1.defined[l] == 0.0) return false;
    if (!(collapsed_distance<W>(c, nu, s, l) > g.gate_of(l))) return false;
  }
  return true;
}

/// The gating question's answer for lane l of a block whose two modes were updated with one
/// candidate plot (nothing kept; the modes' first linearization at the prediction):
/// log Σ_j c_j N(ν_j; 0, S_j), −∞ where the distance to the collapsed predicted plot is above
/// `gate`, NaN where a mode could not score it (ImmEstimator's candidate questions: the modes'
/// densities summed in log space, the distance collapsed_distance's). `c`: normalized_predicted.
template <int D0, int D1, int W>
double candidate_answer(const Mixing<W>& mixing, const double (&c)[2][W],
                        const ModeLanes<D0, W>& mode0, const ModeLanes<D1, W>& mode1, int l,
                        double gate) {
  if (mode0.code[l] != kOk || mode1.code[l] != kOk) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const double* const nu[2][2] = {{mode0.nu[0], mode0.nu[1]}, {mode1.nu[0], mode1.nu[1]}};
  const double* const s[2][3] = {{mode0.s[0], mode0.s[1], mode0.s[2]},
                                 {mode1.s[0], mode1.s[1], mode1.s[2]}};
  const double distance = collapsed_distance<W>(c, nu, s, l);
  if (std::isnan(distance)) return std::numeric_limits<double>::quiet_NaN();
  if (distance > gate) return -std::numeric_limits<double>::infinity();
  ModeVector terms(2);
  terms << mode0.log_likelihood[l] + mixing.log_c[0][l],
      mode1.log_likelihood[l] + mixing.log_c[1][l];
  return log_sum_exp(terms);
}

}  // namespace imm::bank
