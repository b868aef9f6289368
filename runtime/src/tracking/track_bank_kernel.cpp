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
#include "imm/math/lane_isa.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm_cycle.hpp"

namespace imm::bank {
namespace {

// A Gaussian of one mode: mean, then the covariance's upper triangle (cv_position_algebra.hpp).
template <class S>
using Entries = std::array<S, kEntries>;

// What a step that states its NIS keeps of one pack's lanes, in the bank's buffer
// (Block::innovations): per mode j and lane l, at j · kPackLanes + l, the predicted log c_j of the
// mixing and the mode's ν_j and S_j of the update.
struct PackInnovations {
  static constexpr int kPackLanes = 8;
  static constexpr std::ptrdiff_t kEach = std::ptrdiff_t{kMaxModes} * kPackLanes;
  static_assert(kInnovationDoubles == 6 * kEach);
  explicit PackInnovations(double* buffer)
      : log_c(buffer),
        nu0(buffer + kEach),
        nu1(buffer + 2 * kEach),
        s00(buffer + 3 * kEach),
        s01(buffer + 4 * kEach),
        s11(buffer + 5 * kEach) {}
  double* log_c;
  double* nu0;
  double* nu1;
  double* s00;
  double* s01;
  double* s11;
};

// The plain IMM's constant-velocity modes with a Cartesian plot as imm_cycle.hpp's family: a
// mode holds its Gaussian; its step is cv_position_algebra.hpp's prediction and Joseph update.
struct CvPositionFamily {
  static constexpr int kEntries = cv_position::kEntries, kCombined = cv_position::kEntries;
  template <class S>
  struct Plot {
    S x, y;
  };
  double period = 1.0;
  const double* noise = nullptr;  // mode j's Q triangle at j * kTriangle
  double r00 = 0.0, r01 = 0.0, r11 = 0.0;
  // Where not null, the cycle of one pack records its log c_j and the modes' ν_j and S_j here.
  PackInnovations* record = nullptr;

  template <class S, int N, int K>
  [[gnu::always_inline]] inline void record_log_c(int n, const std::array<S, N> (&log_c)[K]) const {
    static_assert(K == 1, "the TrackBank's kernel steps one pack at a time");
    if (record == nullptr) return;
    for (int j = 0; j < n; ++j)
      lane_store(record->log_c + std::ptrdiff_t{j} * PackInnovations::kPackLanes, log_c[0][j]);
  }

  // Σ_i w_i N(mean_i, P_i) collapsed to one Gaussian (eq. 4–5 and 10–11; imm_algebra.hpp).
  template <class S, class Modes>
  [[gnu::always_inline]] inline void mix(int components, const S* weights, Modes&& mode,
                                         Entries<S>& out) const {
    algebra::collapse<kN, S>(
        components, [weights](int i) -> const S& { return weights[i]; },
        [&mode](int i, int a) -> const S& { return mode(i)[a]; },
        [&mode](int i, int a, int c) -> const S& { return mode(i)[kN + sym(a, c)]; },
        [&out](int a) -> S& { return out[a]; },
        [&out](int a, int c) -> S& { return out[kN + sym(a, c)]; });
  }

  // Mode j's prediction in place: x⁻ = F x, P⁻ = F P Fᵀ + Q.
  template <class S>
  [[gnu::always_inline]] inline void predict(int j, Entries<S>& e) const {
    cv_position::predict([&](int i) -> S& { return e[i]; }, period,
                         noise + static_cast<std::ptrdiff_t>(j) * kTriangle);
  }

  // Mode j's prediction and Joseph-form update with H selecting [x, y] (step) for K packs.
  template <class S, int K>
  [[gnu::always_inline]] inline void steps(int j, const Entries<S> (&mixed)[K],
                                           const Entries<S> (&/*current*/)[K],
                                           const Plot<S> (&z)[K], Entries<S> (&updated)[K],
                                           S (&log_likelihood)[K], S (&code)[K]) const {
    for (int k = 0; k < K; ++k) {
      const cv_position::UpdateOutcome<S> o =
          step(noise + static_cast<std::ptrdiff_t>(j) * kTriangle, mixed[k], z[k], updated[k],
               log_likelihood[k], code[k]);
      if (record == nullptr) continue;
      const std::ptrdiff_t at = static_cast<std::ptrdiff_t>(j) * PackInnovations::kPackLanes +
                                static_cast<std::ptrdiff_t>(k) * kLanesOf<S>;
      lane_store(record->nu0 + at, o.nu0);
      lane_store(record->nu1 + at, o.nu1);
      lane_store(record->s00 + at, o.s00);
      lane_store(record->s01 + at, o.s01);
      lane_store(record->s11 + at, o.s11);
    }
  }

  // The n modes of one track at once, mode j in lane j of P: each lane its own Q.
  template <class P>
  [[gnu::always_inline]] inline void steps_across_modes(int n, const Entries<P>& mixed,
                                                        const Entries<P>& /*current*/,
                                                        const Plot<double>& z, Entries<P>& updated,
                                                        P& log_likelihood, P& code) const {
    constexpr int W = kLanesOf<P>;
    P q[kTriangle];
    for (int e = 0; e < kTriangle; ++e) {
      double lanes[W];
      for (int j = 0; j < W; ++j) lanes[j] = noise[(j < n ? j : 0) * kTriangle + e];
      q[e] = lane_load<P>(lanes);
    }
    step(q, mixed, Plot<P>{splat<P>(z.x), splat<P>(z.y)}, updated, log_likelihood, code);
  }

  // The prediction with Q's triangle q (q[i] a double or an S) and the Joseph-form update; S
  // positive definite by Sylvester with kalman_filter.hpp's relative guard, every output finite.
  template <class S, class Q>
  [[gnu::always_inline]] inline cv_position::UpdateOutcome<S> step(
      const Q& q, const Entries<S>& mixed, const Plot<S>& z, Entries<S>& updated, S& log_likelihood,
      S& code) const {
    Entries<S> predicted = mixed;
    cv_position::predict([&](int i) -> S& { return predicted[i]; }, period, q);
    const auto o =
        cv_position::update([&](int e) { return predicted[e]; },
                            [&](int e) -> S& { return updated[e]; }, z.x, z.y, r00, r01, r11);
    log_likelihood = -0.5 * (o.mahalanobis + lane_log(o.det) + 2 * kLogTwoPi);
    code = pick(o.s00 > 0.0,
                pick(o.det > o.threshold, pick(o.finite == 0.0, kOk, kNonFinite), kSingular),
                kSingular);
    return o;
  }

  // A track is one lane.
  template <class S>
  [[gnu::always_inline]] inline S track_code(S code) const {
    return code;
  }
};

static_assert(CycleSlots<CvPositionFamily>::kLogMu == kLogMu &&
              CycleSlots<CvPositionFamily>::kScaledMu == kScaledMu &&
              CycleSlots<CvPositionFamily>::kModeSlots == kModeSlots);

CvPositionFamily family_of(const Block& b) { return {b.period, b.noise, b.r00, b.r01, b.r11}; }
CycleBlock cycle_of(const Block& b) {
  return {b.modes, b.transition, b.log_transition, b.state, b.stride};
}

// The modes' 2-vectors v_j = [v(j, 0), v(j, 1)] and 2 × 2 spreads S_j (upper triangle s(j, 0 … 2):
// s00, s01, s11) collapsed with c_j = exp(log c_j − max) / Σ (log_c(j)), by imm_algebra.hpp's
// normalized and collapse: v̄ = Σ c_j v_j into mean, and the upper triangle of
// Σ c_j (S_j + (v_j − v̄)(v_j − v̄)ᵀ) into t. The NIS's and the predicted plot's collapse.
template <class S, int N, class LogC, class V, class Spread>
[[gnu::always_inline]] inline void collapse_plots(int n, LogC&& log_c, V&& v, Spread&& s,
                                                  S (&mean)[2], S (&t)[3]) {
  std::array<S, N> c;  // NOLINT(cppcoreguidelines-pro-type-member-init): the n written
  algebra::normalized<algebra::LaneFunctions, S>(n, log_c, c);
  algebra::collapse<2, S>(
      n, [&c](int j) -> const S& { return c[j]; }, v,
      [&s](int j, int a, int b) { return s(j, a + b); }, [&mean](int a) -> S& { return mean[a]; },
      [&t](int a, int b) -> S& { return t[a + b]; });
}

// The NIS of the `real` tracks of a pack after its step (track_bank_kernel.hpp: step_tracks) from
// what the cycle recorded: c_j = exp(log c_j − max) / Σ, ν̄ = Σ c_j ν_j,
// S̄ = Σ c_j (S_j + (ν_j − ν̄)(ν_j − ν̄)ᵀ), then ν̄ᵀ S̄⁻¹ ν̄; NaN where a track's code is not kOk
// or S̄ is not positive definite.
template <class S, int N>
[[gnu::always_inline]] inline void state_nis(int modes, const PackInnovations& r,
                                             const Lanes<S>& codes, int real, double* nis) {
  const int n = N == kMaxModes ? modes : N;
  auto at = [](const double* v, int j) {
    return lane_load<S>(v + std::ptrdiff_t{j} * PackInnovations::kPackLanes);
  };
  // The modes' ν_j = [nu0, nu1] and S_j = [[s00, s01], [s01, s11]].
  const double* const nu[2] = {r.nu0, r.nu1};
  const double* const s[3] = {r.s00, r.s01, r.s11};
  S nu_bar[2], s_bar[3];
  collapse_plots<S, N>(
      n, [&](int j) { return at(r.log_c, j); }, [&](int j, int a) { return at(nu[a], j); },
      [&](int j, int e) { return at(s[e], j); }, nu_bar, s_bar);
  const Lanes<S> lanes =
      lanes_of(quadratic_form_2x2(s_bar[0], s_bar[1], s_bar[2], nu_bar[0], nu_bar[1]));
  for (int l = 0; l < real; ++l) {
    const auto u = static_cast<std::size_t>(l);
    nis[l] = codes[u] == kOk ? lanes[u] : std::numeric_limits<double>::quiet_NaN();
  }
}

// One IMM step (seed 000 eq. 4–11) of the `real` tracks that start at lane `t` of block `b`
// (imm_cycle.hpp) in a pack of kLanesOf<S> lanes; a lane whose plot is unusable computes on zeros
// and keeps its state. The lanes past the real ones (there is room for them: a block's lanes are
// whole packs) compute on whatever they hold, a plot at 0, and keep it to the bit.
template <class S, int N>
[[gnu::always_inline]] inline void step(const Block& b, int t, int real = kLanesOf<S>) {
  Lanes<S> zx{}, zy{}, ok{}, active{}, codes{};
  for (std::size_t l = 0; l < static_cast<std::size_t>(real); ++l) {
    const Eigen::Vector2d& z = b.plots[static_cast<std::size_t>(t) + l];
    const bool usable = limits::usable_measurement(z.x()) && limits::usable_measurement(z.y());
    zx[l] = usable ? z.x() : 0.0;
    zy[l] = usable ? z.y() : 0.0;
    ok[l] = usable ? 1.0 : 0.0;
    active[l] = 1.0;
  }
  const CvPositionFamily::Plot<S> plot[1] = {{from_lanes<S>(zx), from_lanes<S>(zy)}};
  const S usable[1] = {from_lanes<S>(ok)}, stepped[1] = {from_lanes<S>(active)};
  CvPositionFamily family = family_of(b);
  PackInnovations recorded(b.innovations);
  if (b.nis != nullptr) family.record = &recorded;
  imm_cycle<S, N, 1>(family, cycle_of(b), t, plot, usable, stepped, codes.data());
  for (std::size_t l = 0; l < static_cast<std::size_t>(real); ++l) {
    b.status[static_cast<std::size_t>(t) + l] = status_of(codes[l]);
  }
  if (b.nis != nullptr) state_nis<S, N>(b.modes, recorded, codes, real, b.nis + t);
}

template <class Pack, int N>
[[gnu::always_inline]] inline void step_block(const Block& b) {
  constexpr int kW = kLanesOf<Pack>;
  int t = 0;
  for (; t + kW <= b.lanes; t += kW) step<Pack, N>(b, t);
  // The rest: one track alone, more in a pack of which they fill a part (a pack costs about as
  // much as one track alone). A step that states the NIS steps one track in a pack too: alone, its
  // modes step across a pack's lanes (imm_cycle.hpp) and record nothing. The same bits either way.
  const int rest = b.lanes - t;
  if (rest == 1 && b.nis == nullptr) {
    step<double, N>(b, t);
  } else if (rest > 0) {
    step<Pack, N>(b, t, rest);
  }
}

// The predicted plot density of the kLanesOf<S> tracks at lane `t`: per mode j the constant of its
// log-density, ẑ_j and S_j⁻¹ (S_j = H P⁻_j Hᵀ + R), then the collapsed ẑ and S̄⁻¹ with
// S̄ = Σ_j c_j (S_j + (ẑ_j − ẑ)(ẑ_j − ẑ)ᵀ), c_j normalized (ImmEstimator::collapse), into the
// prediction slots of `out` (kPlotSlots per mode, then kCollapsedSlots; `b.stride` apart).
template <class S, int N>
[[gnu::always_inline]] inline void predict_plot(const Block& b, int t, double* out) {
  const int n = N == kMaxModes ? b.modes : N;
  const CvPositionFamily family = family_of(b);
  CycleMixing<S, N, 1, CvPositionFamily> p;  // NOLINT(cppcoreguidelines-pro-type-member-init)
  const S active[1] = {splat<S>(1.0)};
  mix_modes<S, N, 1>(family, cycle_of(b), t, active, p);
  for (int j = 0; j < n; ++j) family.predict(j, p.mixed[j][0]);
  auto slot = [&](int index) { return out + index * b.stride + t; };
  // Written for the n modes before they are read.
  std::array<S, N> zx, zy, s00, s01, s11;  // NOLINT(cppcoreguidelines-pro-type-member-init)
  for (int j = 0; j < n; ++j) {
    const Entries<S>& m = p.mixed[j][0];
    zx[j] = m[0];
    zy[j] = m[2];
    s00[j] = m[kN + sym(0, 0)] + b.r00;
    s01[j] = m[kN + sym(0, 2)] + b.r01;
    s11[j] = m[kN + sym(2, 2)] + b.r11;
    const S det = s00[j] * s11[j] - s01[j] * s01[j];
    const S inverse_det = 1.0 / det;
    double* mode = out + static_cast<std::ptrdiff_t>(j * kPlotSlots) * b.stride + t;
    lane_store(mode, p.log_c[0][j] - 0.5 * lane_log(det) - kLogTwoPi);
    lane_store(mode + b.stride, zx[j]);
    lane_store(mode + 2 * b.stride, zy[j]);
    lane_store(mode + 3 * b.stride, s11[j] * inverse_det);
    lane_store(mode + 4 * b.stride, -s01[j] * inverse_det);
    lane_store(mode + 5 * b.stride, s00[j] * inverse_det);
  }
  // The collapsed prediction: ẑ and S̄.
  const std::array<S, N>* const plot[2] = {&zx, &zy};
  const std::array<S, N>* const spread[3] = {&s00, &s01, &s11};
  S z_hat[2], s_bar[3];
  collapse_plots<S, N>(
      n, [&p](int j) { return p.log_c[0][j]; }, [&plot](int j, int a) { return (*plot[a])[j]; },
      [&spread](int j, int e) { return (*spread[e])[j]; }, z_hat, s_bar);
  const S inverse_det = 1.0 / (s_bar[0] * s_bar[2] - s_bar[1] * s_bar[1]);
  const int collapsed = n * kPlotSlots;
  lane_store(slot(collapsed), z_hat[0]);
  lane_store(slot(collapsed + 1), z_hat[1]);
  lane_store(slot(collapsed + 2), s_bar[2] * inverse_det);
  lane_store(slot(collapsed + 3), -s_bar[1] * inverse_det);
  lane_store(slot(collapsed + 4), s_bar[0] * inverse_det);
}

// Every plot of `s` against the kLanesOf<S> tracks at lane `t`: the pack's prediction is read once,
// then each plot's gate statistic, and its mixture log-density unless every track of the pack is
// outside the gate.
template <class S, int N>
[[gnu::always_inline]] inline void score_plots(const Scoring& s, int t) {
  const int n = N == kMaxModes ? s.modes : N;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  auto slot = [&](int index) { return lane_load<S>(s.prediction + index * s.stride + t); };
  // Read for the n modes they are written for.
  // NOLINTNEXTLINE(cppcoreguidelines-pro-type-member-init)
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
  const S gate =
      s.gate_scale == nullptr ? splat<S>(s.gate) : s.gate * lane_load<S>(s.gate_scale + t);
  for (int q = 0; q < s.plot_count; ++q) {
    const Eigen::Vector2d& z = s.plots[q];
    double* to = s.out + q * s.out_stride + t;
    if (!limits::usable_measurement(z.x()) || !limits::usable_measurement(z.y())) {
      lane_store(to, splat<S>(std::numeric_limits<double>::quiet_NaN()));
      continue;
    }
    const S dx = z.x() - cx, dy = z.y() - cy;
    const S d2 = c00 * (dx * dx) + 2.0 * (c01 * (dx * dy)) + c11 * (dy * dy);
    const auto outside = d2 > gate;
    const Lanes<S> outside_lanes = lanes_of(pick(outside, splat<S>(1.0), splat<S>(0.0)));
    if (std::all_of(outside_lanes.begin(), outside_lanes.end(),
                    [](double v) { return v != 0.0; })) {
      lane_store(to, splat<S>(-kInf));
      continue;
    }
    std::array<S, N> terms;  // NOLINT(cppcoreguidelines-pro-type-member-init): the n written
    for (int j = 0; j < n; ++j) {
      const S ex = z.x() - zx[j], ey = z.y() - zy[j];
      const S m = i00[j] * (ex * ex) + 2.0 * (i01[j] * (ex * ey)) + i11[j] * (ey * ey);
      terms[j] = constant[j] - 0.5 * m;
    }
    const S log_likelihood = algebra::log_sum_exp<algebra::LaneFunctions, S>(n, terms);
    lane_store(to, pick(outside, splat<S>(-kInf), log_likelihood));
  }
}

template <class Pack, int N>
[[gnu::always_inline]] inline void predict_plot_block(const Block& b, double* out) {
  constexpr int kW = kLanesOf<Pack>;
  int t = 0;
  for (; t + kW <= b.lanes; t += kW) predict_plot<Pack, N>(b, t, out);
  for (; t < b.lanes; ++t) predict_plot<double, N>(b, t, out);
}

template <class Pack, int N>
[[gnu::always_inline]] inline void score_plot_block(const Scoring& s) {
  constexpr int kW = kLanesOf<Pack>;
  int t = 0;
  for (; t + kW <= s.tracks; t += kW) score_plots<Pack, N>(s, t);
  for (; t < s.tracks; ++t) score_plots<double, N>(s, t);
}

// Each block function for each instruction set, its pack one vector of it (lane_isa.hpp), the
// cycle inlined. They are chosen outside, with the mode count: a lambda inside a function compiled
// for an instruction set is compiled for the baseline.
// NOLINTBEGIN(bugprone-macro-parentheses): `target` is an attribute.
#define IMM_KERNELS_FOR(isa, target, width)                                           \
  template <int N>                                                                    \
  [[gnu::flatten]] target void step_tracks_for_##isa(const Block& b) {                \
    step_block<LanePackOf<width>, N>(b);                                              \
  }                                                                                   \
  template <int N>                                                                    \
  [[gnu::flatten]] target void predict_plots_for_##isa(const Block& b, double* out) { \
    predict_plot_block<LanePackOf<width>, N>(b, out);                                 \
  }                                                                                   \
  template <int N>                                                                    \
  [[gnu::flatten]] target void score_plots_for_##isa(const Scoring& s) {              \
    score_plot_block<LanePackOf<width>, N>(s);                                        \
  }
IMM_FOR_EACH_LANE_ISA(IMM_KERNELS_FOR)
#undef IMM_KERNELS_FOR
// NOLINTEND(bugprone-macro-parentheses)

}  // namespace

void step_tracks(const Block& b) {
  with_mode_count(b.modes, [&](auto n) {
    constexpr int N = decltype(n)::value;
    for_lane_isa(lane_isa(), step_tracks_for_avx512<N>, step_tracks_for_avx2<N>,
                 step_tracks_for_baseline<N>)(b);
  });
}

void predict_plots(const Block& b, double* prediction) {
  with_mode_count(b.modes, [&](auto n) {
    constexpr int N = decltype(n)::value;
    for_lane_isa(lane_isa(), predict_plots_for_avx512<N>, predict_plots_for_avx2<N>,
                 predict_plots_for_baseline<N>)(b, prediction);
  });
}

void score_plots(const Scoring& s) {
  with_mode_count(s.modes, [&](auto n) {
    constexpr int N = decltype(n)::value;
    for_lane_isa(lane_isa(), score_plots_for_avx512<N>, score_plots_for_avx2<N>,
                 score_plots_for_baseline<N>)(s);
  });
}

}  // namespace imm::bank
