// SPDX-License-Identifier: Apache-2.0
// 64-byte vectors by value inside this file only (lane_math.hpp says why that is harmless).
#pragma GCC diagnostic ignored "-Wpsabi"

#include "track_bank_kernel.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <type_traits>

#include "imm/core/physical_limits.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"

namespace imm::bank {
namespace {

// The number types of one step: S is a double (one track) or a LanePack (kLanePackWidth tracks,
// one per element). Every statement below is the same IEEE operation for both, so a track gives
// the same bits in a pack and alone (the project compiles with -ffp-contract=off). Loads, stores
// and splats are lane_math.hpp's.
// a and b of two comparisons: bools for a double, masks for a LanePack.
template <class Mask>
[[gnu::always_inline]] inline Mask both(Mask a, Mask b) {
  if constexpr (std::is_same_v<Mask, bool>) {
    return a && b;
  } else {
    return a & b;
  }
}

// The lanes of a value, as doubles (for the few scalar decisions per step).
template <class S>
using Lanes = std::array<double, kLanesOf<S>>;
template <class S>
[[gnu::always_inline]] inline Lanes<S> lanes_of(const S& value) {
  Lanes<S> out;
  lane_store(out.data(), value);
  return out;
}
template <class S>
[[gnu::always_inline]] inline S from_lanes(const Lanes<S>& lanes) {
  return lane_load<S>(lanes.data());
}

// A Gaussian of one mode: mean, then the covariance's upper triangle (cv_position_algebra.hpp).
template <class S>
using Entries = std::array<S, kEntries>;

// Σ_i w_i N(mean_i, P_i) collapsed to one Gaussian (eq. 4–5 and 10–11), each sum over i = 0, 1, …
template <class S>
[[gnu::always_inline]] inline void moment_match(int components, const S* weights,
                                                const Entries<S>* modes, Entries<S>& out) {
  for (int a = 0; a < kN; ++a) {
    S sum = splat<S>(0.0);
    for (int i = 0; i < components; ++i) sum += weights[i] * modes[i][a];
    out[a] = sum;
  }
  for (int a = 0; a < kN; ++a) {
    for (int c = a; c < kN; ++c) {
      S sum = splat<S>(0.0);
      for (int i = 0; i < components; ++i) {
        sum += weights[i] *
               (modes[i][kN + sym(a, c)] + (modes[i][a] - out[a]) * (modes[i][c] - out[c]));
      }
      out[kN + sym(a, c)] = sum;
    }
  }
}

// Where c̃_j = Σ_i p_ij μ̃_i underflowed to 0 (possible only with zero transition entries): the
// exact log-sum-exp of log c_j and the weights from it, lane by lane (ImmEstimator's fallback).
template <class S>
void exact_predicted(const Block& b, const S* log_mu, const S* predicted, S* log_c, S* weights) {
  const int n = b.modes;
  for (int j = 0; j < n; ++j) {
    const Lanes<S> c = lanes_of(predicted[j]);
    if (std::none_of(c.begin(), c.end(), [](double v) { return !(v > 0.0); })) continue;
    Lanes<S> out = lanes_of(log_c[j]);
    std::array<Lanes<S>, kMaxModes> w{};  // n ≤ kMaxModes
    for (int i = 0; i < n; ++i) w[static_cast<std::size_t>(i)] = lanes_of(weights[j * n + i]);
    for (std::size_t l = 0; l < c.size(); ++l) {
      if (c[l] > 0.0) continue;
      double largest = -std::numeric_limits<double>::infinity();
      for (int i = 0; i < n; ++i)
        largest = std::max(largest, b.log_transition[i * n + j] + lanes_of(log_mu[i])[l]);
      double value = largest;
      if (std::isfinite(largest)) {
        double sum = 0.0;
        for (int i = 0; i < n; ++i)
          sum += std::exp(b.log_transition[i * n + j] + lanes_of(log_mu[i])[l] - largest);
        // sum ≥ 1: the largest term is exp(0).
        value = largest + std::log(sum);  // cppcheck-suppress invalidFunctionArg
      }
      out[l] = value;
      for (int i = 0; i < n; ++i) {
        // Unreachable mode: it keeps its own estimate as the initial condition.
        w[static_cast<std::size_t>(i)][l] =
            !std::isfinite(value)
                ? (i == j ? 1.0 : 0.0)
                : std::exp(b.log_transition[i * n + j] + lanes_of(log_mu[i])[l] - value);
      }
    }
    log_c[j] = from_lanes<S>(out);
    for (int i = 0; i < n; ++i) weights[j * n + i] = from_lanes<S>(w[static_cast<std::size_t>(i)]);
  }
}

// The first half of an IMM cycle (seed 000 eq. 4–6 and each mode's prediction) of the kLanesOf<S>
// tracks that start at lane `t` of block `b`, whose IMM has N modes (N = kMaxModes: b.modes ≤ N,
// the loops then run to b.modes): the modes' and μ's stored state, log c_j, and each mode's
// prediction from its mixed initial condition.
template <class S, int N>
struct Predicted {
  std::array<Entries<S>, N> modes, mixed;
  std::array<S, N> log_mu, scaled_mu, log_c;
};

template <class S, int N>
[[gnu::always_inline]] inline void predict(const Block& b, int t, Predicted<S, N>& p) {
  const int n = N == kMaxModes ? b.modes : N;
  auto st = [&](int j, int entry) { return b.state + (j * kModeSlots + entry) * b.stride + t; };
  constexpr double kInf = std::numeric_limits<double>::infinity();
  auto& modes = p.modes;
  auto& mixed = p.mixed;
  auto& log_mu = p.log_mu;
  auto& scaled_mu = p.scaled_mu;
  auto& log_c = p.log_c;
  std::array<S, N> predicted;
  std::array<S, N * N> weights;
  for (int i = 0; i < n; ++i) {
    for (int e = 0; e < kEntries; ++e) modes[i][e] = lane_load<S>(st(i, e));
    log_mu[i] = lane_load<S>(st(i, kLogMu));
    scaled_mu[i] = lane_load<S>(st(i, kScaledMu));
  }

  // Predicted mode probabilities c̃_j = Σ_i p_ij μ̃_i with μ̃ = μ / max μ (as ImmEstimator does),
  // mixing weights μ_ij = p_ij μ̃_i / c̃_j (eq. 6) and log c_j = log c̃_j + max_i log μ_i.
  S shift = splat<S>(-kInf);
  for (int i = 0; i < n; ++i) shift = pick(shift < log_mu[i], log_mu[i], shift);
  for (int j = 0; j < n; ++j) {
    S c = splat<S>(0.0);
    for (int i = 0; i < n; ++i) c += b.transition[i * n + j] * scaled_mu[i];
    predicted[j] = c;
    const S inverse = 1.0 / c;
    for (int i = 0; i < n; ++i)
      weights[j * n + i] = b.transition[i * n + j] * scaled_mu[i] * inverse;
    log_c[j] = lane_log(c) + shift;
  }
  exact_predicted(b, log_mu.data(), predicted.data(), log_c.data(), weights.data());

  // Mixed initial conditions (eq. 4–5) and the prediction x⁻ = F x, P⁻ = F P Fᵀ + Q.
  for (int j = 0; j < n; ++j) {
    moment_match(n, weights.data() + j * n, modes.data(), mixed[j]);
    cv_position::predict([&](int e) -> S& { return mixed[j][e]; }, b.period,
                         b.noise + static_cast<std::ptrdiff_t>(j) * kTriangle);
  }
}

// One IMM step (seed 000 eq. 4–11) of the kLanesOf<S> tracks that start at lane `t` of block `b`.
template <class S, int N>
[[gnu::always_inline]] inline void step(const Block& b, int t) {
  const int n = N == kMaxModes ? b.modes : N;
  auto st = [&](int j, int entry) { return b.state + (j * kModeSlots + entry) * b.stride + t; };
  auto combined = [&](int entry) { return b.state + (n * kModeSlots + entry) * b.stride + t; };
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Predicted<S, N> p;
  predict<S, N>(b, t, p);
  const auto& modes = p.modes;
  const auto& mixed = p.mixed;
  const auto& log_mu = p.log_mu;
  const auto& scaled_mu = p.scaled_mu;
  const auto& log_c = p.log_c;
  std::array<Entries<S>, N> updated;

  // The plots: a lane whose plot is unusable computes on zeros and keeps its state.
  Lanes<S> zx{}, zy{}, ok{};
  for (std::size_t l = 0; l < ok.size(); ++l) {
    const Eigen::Vector2d& z = b.plots[static_cast<std::size_t>(t) + l];
    const bool usable = limits::usable_measurement(z.x()) && limits::usable_measurement(z.y());
    zx[l] = usable ? z.x() : 0.0;
    zy[l] = usable ? z.y() : 0.0;
    ok[l] = usable ? 1.0 : 0.0;
  }

  // The Joseph-form update with H selecting [x, y] (cv_position_algebra.hpp).
  std::array<S, N> s00, det, mahalanobis, threshold, finite;
  for (int j = 0; j < n; ++j) {
    const auto o = cv_position::update([&](int e) { return mixed[j][e]; },
                                       [&](int e) -> S& { return updated[j][e]; },
                                       from_lanes<S>(zx), from_lanes<S>(zy), b.r00, b.r01, b.r11);
    s00[j] = o.s00;
    det[j] = o.det;
    mahalanobis[j] = o.mahalanobis;
    threshold[j] = o.threshold;
    finite[j] = o.finite;
  }

  // The posterior mode probabilities in log space (eq. 8–9); a lane that fails computes them too
  // and drops them below.
  std::array<S, N> centered, scaled;
  S top = splat<S>(-kInf);
  for (int j = 0; j < n; ++j) {
    centered[j] = -0.5 * (mahalanobis[j] + lane_log(det[j]) + 2 * kLogTwoPi) + log_c[j];
    top = pick(top < centered[j], centered[j], top);
  }
  S sum = splat<S>(0.0);
  for (int j = 0; j < n; ++j) {
    centered[j] = centered[j] - top;
    scaled[j] = lane_exp(centered[j]);
    sum += scaled[j];
  }
  const S log_sum = lane_log(sum);

  // Statuses: S positive definite (Sylvester, with kalman_filter.hpp's relative guard), every
  // output finite, some likelihood that did not underflow; lane by lane only where one fails.
  S failed = splat<S>(0.0);
  for (int j = 0; j < n; ++j) {
    failed += pick(both(s00[j] > 0.0, det[j] > threshold[j]), 0.0, 1.0) + finite[j];
  }
  failed += top - top;  // NaN where every likelihood underflowed (top = −∞)
  const Lanes<S> failed_lanes = lanes_of(failed);
  const Lanes<S> top_lanes = lanes_of(top);
  for (std::size_t l = 0; l < ok.size(); ++l) {
    StepStatus& status = b.status[static_cast<std::size_t>(t) + l];
    if (ok[l] == 0.0) {
      status = StepStatus::kInvalidMeasurement;
      continue;
    }
    status = StepStatus::kOk;
    if (failed_lanes[l] == 0.0) continue;
    for (int j = 0; j < n && status == StepStatus::kOk; ++j) {
      if (!(lanes_of(s00[j])[l] > 0.0) || !(lanes_of(det[j])[l] > lanes_of(threshold[j])[l])) {
        status = StepStatus::kSingularInnovation;
      } else if (lanes_of(finite[j])[l] != 0.0) {
        status = StepStatus::kNonFiniteResult;
      }
    }
    if (status == StepStatus::kOk && !std::isfinite(top_lanes[l])) {
      status = StepStatus::kProbabilityUnderflow;  // every likelihood underflowed
    }
    if (status != StepStatus::kOk) ok[l] = 0.0;
  }
  const auto commit = from_lanes<S>(ok) != 0.0;

  // Commit the tracks that succeeded: log μ_j = (ℓ_j − top) − log Σ, μ̃_j, the modes and their
  // combination (eq. 10–11).
  std::array<S, N> posterior;
  const S inverse_sum = 1.0 / sum;
  for (int j = 0; j < n; ++j) {
    posterior[j] = scaled[j] * inverse_sum;
    lane_store(st(j, kLogMu), pick(commit, centered[j] - log_sum, log_mu[j]));
    lane_store(st(j, kScaledMu), pick(commit, scaled[j], scaled_mu[j]));
    for (int e = 0; e < kEntries; ++e)
      lane_store(st(j, e), pick(commit, updated[j][e], modes[j][e]));
  }
  Entries<S> estimate;
  moment_match(n, posterior.data(), updated.data(), estimate);
  for (int e = 0; e < kEntries; ++e) {
    lane_store(combined(e), pick(commit, estimate[e], lane_load<S>(combined(e))));
  }
}

// The fewest tracks left over after the whole packs that are stepped as a pack padded with copies
// of their last track rather than one by one: a pack costs about as much as two single tracks.
constexpr int kPaddedPack = 3;

// Steps `b`'s lanes [t, b.lanes), fewer than a pack, as one pack: copies them into a pack-wide
// block, the missing lanes repeating the last one, and copies the real lanes back. A lane's
// arithmetic does not depend on its neighbours, so the real lanes get their own bits.
template <int N>
[[gnu::always_inline]] inline void step_padded(const Block& b, int t) {
  constexpr int kW = kLanePackWidth;
  const int n = N == kMaxModes ? b.modes : N;
  const int slots = n * kModeSlots + kEntries;
  const int real = b.lanes - t;
  std::array<double, (kMaxModes * kModeSlots + kEntries) * kW> state;
  std::array<Eigen::Vector2d, kW> plots;
  std::array<StepStatus, kW> status{};
  const auto source = [&](int l) { return t + std::min(l, real - 1); };
  for (int e = 0; e < slots; ++e) {
    for (int l = 0; l < kW; ++l) state[e * kW + l] = b.state[e * b.stride + source(l)];
  }
  for (int l = 0; l < kW; ++l) plots[l] = b.plots[source(l)];
  Block pack = b;
  pack.lanes = kW;
  pack.state = state.data();
  pack.stride = kW;
  pack.plots = plots.data();
  pack.status = status.data();
  step<LanePack, N>(pack, 0);
  for (int e = 0; e < slots; ++e) {
    for (int l = 0; l < real; ++l) b.state[e * b.stride + t + l] = state[e * kW + l];
  }
  for (int l = 0; l < real; ++l) b.status[t + l] = status[l];
}

template <int N>
[[gnu::always_inline]] inline void step_block(const Block& b) {
  int t = 0;
  for (; t + kLanePackWidth <= b.lanes; t += kLanePackWidth) step<LanePack, N>(b, t);
  if (b.lanes - t >= kPaddedPack) return step_padded<N>(b, t);
  for (; t < b.lanes; ++t) step<double, N>(b, t);
}

// The predicted plot density of the kLanesOf<S> tracks at lane `t`: per mode j the constant of its
// log-density, ẑ_j and S_j⁻¹ (S_j = H P⁻_j Hᵀ + R), then the collapsed ẑ and S̄⁻¹ with
// S̄ = Σ_j c_j (S_j + (ẑ_j − ẑ)(ẑ_j − ẑ)ᵀ), c_j normalized (ImmEstimator::collapse), into the
// prediction slots of `out` (kPlotSlots per mode, then kCollapsedSlots; `b.stride` apart).
template <class S, int N>
[[gnu::always_inline]] inline void predict_plot(const Block& b, int t, double* out) {
  const int n = N == kMaxModes ? b.modes : N;
  Predicted<S, N> p;
  predict<S, N>(b, t, p);
  auto slot = [&](int index) { return out + index * b.stride + t; };
  std::array<S, N> zx, zy, s00, s01, s11, c;
  S top = splat<S>(-std::numeric_limits<double>::infinity());
  for (int j = 0; j < n; ++j) top = pick(top < p.log_c[j], p.log_c[j], top);
  S total = splat<S>(0.0);
  for (int j = 0; j < n; ++j) {
    const Entries<S>& m = p.mixed[j];
    zx[j] = m[0];
    zy[j] = m[2];
    s00[j] = m[kN + sym(0, 0)] + b.r00;
    s01[j] = m[kN + sym(0, 2)] + b.r01;
    s11[j] = m[kN + sym(2, 2)] + b.r11;
    const S det = s00[j] * s11[j] - s01[j] * s01[j];
    const S inverse_det = 1.0 / det;
    double* mode = out + (j * kPlotSlots) * b.stride + t;
    lane_store(mode, p.log_c[j] - 0.5 * lane_log(det) - kLogTwoPi);
    lane_store(mode + b.stride, zx[j]);
    lane_store(mode + 2 * b.stride, zy[j]);
    lane_store(mode + 3 * b.stride, s11[j] * inverse_det);
    lane_store(mode + 4 * b.stride, -s01[j] * inverse_det);
    lane_store(mode + 5 * b.stride, s00[j] * inverse_det);
    c[j] = lane_exp(p.log_c[j] - top);
    total += c[j];
  }
  S cx = splat<S>(0.0), cy = splat<S>(0.0);
  for (int j = 0; j < n; ++j) {
    c[j] = c[j] / total;
    cx += c[j] * zx[j];
    cy += c[j] * zy[j];
  }
  S t00 = splat<S>(0.0), t01 = splat<S>(0.0), t11 = splat<S>(0.0);
  for (int j = 0; j < n; ++j) {
    const S dx = zx[j] - cx, dy = zy[j] - cy;
    t00 += c[j] * (s00[j] + dx * dx);
    t01 += c[j] * (s01[j] + dx * dy);
    t11 += c[j] * (s11[j] + dy * dy);
  }
  const S inverse_det = 1.0 / (t00 * t11 - t01 * t01);
  const int collapsed = n * kPlotSlots;
  lane_store(slot(collapsed), cx);
  lane_store(slot(collapsed + 1), cy);
  lane_store(slot(collapsed + 2), t11 * inverse_det);
  lane_store(slot(collapsed + 3), -t01 * inverse_det);
  lane_store(slot(collapsed + 4), t00 * inverse_det);
}

// Every plot of `s` against the kLanesOf<S> tracks at lane `t`: the pack's prediction is read once,
// then each plot's gate statistic, and its mixture log-density unless every track of the pack is
// outside the gate.
template <class S, int N>
[[gnu::always_inline]] inline void score_plots(const Scoring& s, int t) {
  const int n = N == kMaxModes ? s.modes : N;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  auto slot = [&](int index) { return lane_load<S>(s.prediction + index * s.stride + t); };
  std::array<S, N> constant, zx, zy, i00, i01, i11;
  for (int j = 0; j < n; ++j) {
    constant[j] = slot(j * kPlotSlots);
    zx[j] = slot(j * kPlotSlots + 1);
    zy[j] = slot(j * kPlotSlots + 2);
    i00[j] = slot(j * kPlotSlots + 3);
    i01[j] = slot(j * kPlotSlots + 4);
    i11[j] = slot(j * kPlotSlots + 5);
  }
  const int collapsed = n * kPlotSlots;
  const S cx = slot(collapsed), cy = slot(collapsed + 1);
  const S c00 = slot(collapsed + 2), c01 = slot(collapsed + 3), c11 = slot(collapsed + 4);
  for (int q = 0; q < s.plot_count; ++q) {
    const Eigen::Vector2d& z = s.plots[q];
    double* to = s.out + q * s.out_stride + t;
    if (!limits::usable_measurement(z.x()) || !limits::usable_measurement(z.y())) {
      lane_store(to, splat<S>(std::numeric_limits<double>::quiet_NaN()));
      continue;
    }
    const S dx = z.x() - cx, dy = z.y() - cy;
    const S d2 = c00 * (dx * dx) + 2.0 * (c01 * (dx * dy)) + c11 * (dy * dy);
    const auto outside = d2 > s.gate;
    const Lanes<S> outside_lanes = lanes_of(pick(outside, splat<S>(1.0), splat<S>(0.0)));
    if (std::all_of(outside_lanes.begin(), outside_lanes.end(),
                    [](double v) { return v != 0.0; })) {
      lane_store(to, splat<S>(-kInf));
      continue;
    }
    std::array<S, N> terms;
    S top = splat<S>(-kInf);
    for (int j = 0; j < n; ++j) {
      const S ex = z.x() - zx[j], ey = z.y() - zy[j];
      const S m = i00[j] * (ex * ex) + 2.0 * (i01[j] * (ex * ey)) + i11[j] * (ey * ey);
      terms[j] = constant[j] - 0.5 * m;
      top = pick(top < terms[j], terms[j], top);
    }
    S sum = splat<S>(0.0);
    for (int j = 0; j < n; ++j) sum += lane_exp(terms[j] - top);
    const S log_likelihood = pick(top == -kInf, top, top + lane_log(sum));
    lane_store(to, pick(outside, splat<S>(-kInf), log_likelihood));
  }
}

template <int N>
[[gnu::always_inline]] inline void predict_plot_block(const Block& b, double* out) {
  int t = 0;
  for (; t + kLanePackWidth <= b.lanes; t += kLanePackWidth) predict_plot<LanePack, N>(b, t, out);
  for (; t < b.lanes; ++t) predict_plot<double, N>(b, t, out);
}

template <int N>
[[gnu::always_inline]] inline void score_plot_block(const Scoring& s) {
  int t = 0;
  for (; t + kLanePackWidth <= s.tracks; t += kLanePackWidth) score_plots<LanePack, N>(s, t);
  for (; t < s.tracks; ++t) score_plots<double, N>(s, t);
}

// f(std::integral_constant<int, N>{}) with N = `modes` for the common sizes (their loops
// unrolled), kMaxModes for any other (the loops then run to the block's mode count).
template <class F>
[[gnu::always_inline]] inline void with_mode_count(int modes, F&& f) {
  switch (modes) {
    case 1:
      return f(std::integral_constant<int, 1>{});
    case 2:
      return f(std::integral_constant<int, 2>{});
    case 3:
      return f(std::integral_constant<int, 3>{});
    case 4:
      return f(std::integral_constant<int, 4>{});
    default:
      return f(std::integral_constant<int, kMaxModes>{});
  }
}

}  // namespace

[[gnu::flatten]] IMM_VECTOR_CLONES void step_tracks(const Block& b) {
  with_mode_count(b.modes, [&](auto n) { step_block<decltype(n)::value>(b); });
}

[[gnu::flatten]] IMM_VECTOR_CLONES void predict_plots(const Block& b, double* prediction) {
  with_mode_count(b.modes, [&](auto n) { predict_plot_block<decltype(n)::value>(b, prediction); });
}

[[gnu::flatten]] IMM_VECTOR_CLONES void score_plots(const Scoring& s) {
  with_mode_count(s.modes, [&](auto n) { score_plot_block<decltype(n)::value>(s); });
}

}  // namespace imm::bank
