// SPDX-License-Identifier: Apache-2.0
#pragma once
// What the two modes' innovations answer in the banks of two-mode IMMs (two_mode_lanes.hpp):
// the NIS a step states and the end of a step with it (finish_and_keep), the collapsed distance
// of the gate, and a block's share of the gating matrix (score_plots), each as the one-track
// filter's ImmEstimator::innovation, candidate_distance and candidate_log_likelihood. Not
// installed.

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <span>

#include "imm/math/log_sum_exp.hpp"
#include "two_mode_lanes.hpp"

namespace imm::bank {

/// One block's share of a gating matrix: its first `lanes` tracks (their slots `stride` apart from
/// `state`, as BlockStep's) against `plots`, column q of the block's rows at out + q · out_stride.
struct GatingBlock {
  double* state = nullptr;  // slot 0 at the block's first lane
  std::ptrdiff_t stride = 0;
  std::span<const Eigen::Vector2d> plots;
  double gate = 0.0;
  double* out = nullptr;
  std::ptrdiff_t out_stride = 0;
  int lanes = 0;
  const double* gate_scale = nullptr;  // per lane from the block's first, or null: every factor 1

  /// Slot `entry` at the block's first lane.
  [[nodiscard]] double* slot(int entry) const { return state + entry * stride; }
  /// Lane l's gate: gate × gate_scale[l].
  [[nodiscard]] double gate_of(int l) const {
    return gate_scale == nullptr ? gate : gate * gate_scale[l];
  }
};

/// The gating matrix `out` of `plots` in blocks of kBlock tracks of a bank whose slot 0 starts at
/// `state`: score(block) per block; gate_scale: a factor per track, or null.
template <int kBlock, class Score>
void score_in_blocks(std::span<const Eigen::Vector2d> plots, double gate, const double* gate_scale,
                     double* state, std::ptrdiff_t stride, Eigen::Ref<Eigen::MatrixXd> out,
                     Score&& score) {
  for (Eigen::Index first = 0; first < out.rows(); first += kBlock) {
    const GatingBlock block{state + first,
                            stride,
                            plots,
                            gate,
                            out.data() + first,
                            out.outerStride(),
                            static_cast<int>(std::min<Eigen::Index>(kBlock, out.rows() - first)),
                            gate_scale == nullptr ? nullptr : gate_scale + first};
    score(block);
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
  Eigen::Vector2d mean;
  Eigen::Matrix2d S;
  algebra::collapse<2, double>(
      2, [&c](int j) { return c[j]; }, [&nu](int j, int a) { return nu[j](a); },
      [&Sj](int j, int a, int b) { return Sj[j](a, b); },
      [&mean](int a) -> double& { return mean(a); },
      [&S](int a, int b) -> double& { return S(a, b); });
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

/// The end of a block's step once both modes have updated: the posterior μ, each lane's code and
/// whether it commits (finish, into `commit`; a lane's plot is usable where both components are
/// numbers); where block.nis is not null, the block's tracks' NIS (step_nis, the modes'
/// innovations rewritten by to_plot); then log μ (slots `log_mu` and `log_mu` + 1) and both
/// modes' slots in the lanes that commit. A bank keeps its own slots after.
template <int D0, int D1, int W, class ToPlot>
[[gnu::always_inline]] inline void finish_and_keep(const Mixing<W>& mixing,
                                                   const std::array<ModeSlots, 2>& slots,
                                                   int log_mu, const ModeLanes<D0, W>& mode0,
                                                   const ModeLanes<D1, W>& mode1,
                                                   const BlockStep& block, ToPlot&& to_plot,
                                                   double* commit) {
  auto st = [&](int entry) { return block.slot(entry); };
  double usable[W], posterior[2][W];
  IMM_LANES usable[l] = pick((block.z0[l] == block.z0[l]) & (block.z1[l] == block.z1[l]), 1.0, 0.0);
  finish<D0, D1, W>(mixing, mode0, mode1, usable, block.stepped, posterior, block.code, commit);
  if (block.nis != nullptr)
    step_nis<D0, D1, W>(mixing, mode0, mode1, block.code, block.lanes, to_plot, block.nis);
  keep<W>(st, log_mu, posterior[0], commit);
  keep<W>(st, log_mu + 1, posterior[1], commit);
  keep_mode<D0, W>(st, slots[0], mode0, commit);
  keep_mode<D1, W>(st, slots[1], mode1, commit);
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

/// One block's share of a gating matrix (`g`) once both modes are predicted: per plot, NaN for an
/// unusable one; else linearize(z, lin) gives both modes' first linearizations at their
/// predictions, a plot outside every lane's gate is −∞ without an update, and otherwise both modes
/// update with it (a trial: the prediction stays for the next plot) and each lane's answer is
/// candidate_answer's.
template <int D0, int D1, int W, class Linearize>
[[gnu::always_inline]] inline void score_plots(const Mixing<W>& mixing, ModeLanes<D0, W>& mode0,
                                               ModeLanes<D1, W>& mode1, const GatingBlock& g,
                                               Linearize&& linearize) {
  double c[2][W];
  normalized_predicted<W>(mixing, c);
  for (std::size_t q = 0; q < g.plots.size(); ++q) {
    double* column = g.out + static_cast<std::ptrdiff_t>(q) * g.out_stride;
    const Eigen::Vector2d& z = g.plots[q];
    if (!limits::usable_measurement(z)) {
      std::fill(column, column + g.lanes, std::numeric_limits<double>::quiet_NaN());
      continue;
    }
    Linearization<W> lin[2];  // NOLINT(cppcoreguidelines-pro-type-member-init): linearize writes
    linearize(z, lin);
    if (all_outside_the_gate<D0, D1, W>(c, lin[0], mode0, lin[1], mode1, g)) {
      std::fill(column, column + g.lanes, -std::numeric_limits<double>::infinity());
      continue;
    }
    update_mode<D0, W>(lin[0], mode0);
    update_mode<D1, W>(lin[1], mode1);
    for (int l = 0; l < g.lanes; ++l)
      column[l] = candidate_answer<D0, D1, W>(mixing, c, mode0, mode1, l, g.gate_of(l));
  }
}

}  // namespace imm::bank
