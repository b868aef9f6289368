// SPDX-License-Identifier: Apache-2.0
#pragma once
// The IMM cycle of a track bank (seed 000 eq. 4–11: the predicted mode probabilities, the mixing,
// each mode's step, the posterior in log space, the combination, the commit), written once over a
// number type S — a double for one lane, a LanePack for one lane per element — and a filter
// family F that says what a mode holds and how it steps. The TrackBank's kernel and the GA-fuzzy
// bank are its instances. Every statement is the same IEEE operation for a double and for each
// element of a pack (the project compiles with -ffp-contract=off), so a lane gives the same bits
// in a pack and alone, whatever its neighbours. Not installed.
//
// A family F provides:
//   kEntries, kCombined    a mode's stored entries; the combined estimate's (the first kCombined
//                          of a mode's entries are its estimate, any others its own state)
//   Plot<S>                what a lane's plot is
//   mix(n, w, mode, out)   Σ_i w_i mode(i) collapsed to one Gaussian (eq. 4–5 and 10–11)
//   steps<S, K>(j, mixed, current, z, updated, log_likelihood, code)
//                          mode j's step of K packs from their mixed conditions: the updated
//                          entries, log N(ν; 0, S) and a code (kOk, kSingular or kNonFinite)
//   track_code(code)       the code a lane commits under (a track of several lanes fails as one)
// and may provide
//   kLibmProbabilities     true where the mode probabilities are ImmEstimator's arithmetic: μ̃
//                          from log μ, the weights divided by c̃, libm's exp and log lane by lane
//                          (a family whose step is a discontinuous function of the mixed
//                          condition, as the FCM-IMM's window clustering with its stopping rule,
//                          stays with its one-track filter only so); such a family's one track
//                          does not take the steps_across_modes path
//   kStoresCombined        false where the combined estimate is not kept in the state (the bank
//                          combines a track's modes when it is asked for its estimate)
//   record_log_c<S, N, K>(n, log_c)
//                          is given the predicted log c_j of the K packs after the mixing
//   steps_across_modes<P>(n, mixed, current, z, updated, log_likelihood, code)
//                          the step of modes 0 … n − 1 of one track at once, mode j in lane j of
//                          a pack P (n ≤ 8; the lanes past n compute on copies and are not
//                          read), each lane the same operations as steps<double, 1>(j, …)
//
// The state: slots `stride` apart, mode j's entries at j · (kEntries + 2) + e, then its log μ and
// μ̃ = μ / max μ; after the modes the combined estimate.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <type_traits>
#include <utility>

#include "axis_lane_bank.hpp"
#include "imm/estimation/imm_algebra.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/math/linear_algebra.hpp"
#include "imm/tracking/lane_storage.hpp"

// Arrays of N modes are filled to b.modes and read no further; GCC cannot see that for N =
// kMaxModes.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

namespace imm::bank {

/// What a cycle reads and writes besides the family: Π (and log Π) at i · modes + j, the state
/// slots (`stride` apart, offset to the block's first lane).
struct CycleBlock {
  int modes = 0;
  const double* transition = nullptr;
  const double* log_transition = nullptr;
  double* state = nullptr;
  std::ptrdiff_t stride = 0;
};

/// Whether a cycle of family F writes the combined estimate into the state.
template <class F>
constexpr bool kStoresCombined = [] {
  if constexpr (requires { F::kStoresCombined; }) {
    return F::kStoresCombined;
  } else {
    return true;
  }
}();

/// The slots of a family's state: per mode, then the combined estimate.
template <class F>
struct CycleSlots {
  static constexpr int kLogMu = F::kEntries, kScaledMu = F::kEntries + 1,
                       kModeSlots = imm_mode_slot(1, F::kEntries, 0);
  /// Entry `entry` of mode j (j = the mode count: of the combined estimate) at lane `lane`.
  static double* at(const CycleBlock& b, int j, int entry, int lane) {
    return b.state + imm_mode_slot(j, F::kEntries, entry) * b.stride + lane;
  }
};

/// Whether family F's mode probabilities take libm's exp and log (see the file comment).
template <class F>
constexpr bool kLibmProbabilities = [] {
  if constexpr (requires { F::kLibmProbabilities; }) {
    return F::kLibmProbabilities;
  } else {
    return false;
  }
}();

/// The exp and log of family F's mode probabilities (imm_algebra.hpp): libm's, lane by lane, where
/// kLibmProbabilities, else lane_exp and lane_log.
template <class F>
using ProbabilityFunctions =
    std::conditional_t<kLibmProbabilities<F>, algebra::LibmFunctions, algebra::LaneFunctions>;
/// How family F's weights divide by their sum: as ImmEstimator where kLibmProbabilities, else by
/// the sum's inverse.
template <class F>
constexpr algebra::Division kDivision =
    kLibmProbabilities<F> ? algebra::Division::kDivide : algebra::Division::kInverse;
/// The pack that holds one lane per mode of N ≤ 8 modes: 2, 4 or 8 lanes.
template <std::size_t N>
using ModePack = algebra::LaneFunctions::ModePack<N>;

/// The lanes of a value, as doubles (imm_algebra.hpp).
using algebra::from_lanes;
using algebra::Lanes;
using algebra::lanes_of;

/// The first half of a cycle of K packs of N modes (N ≥ b.modes; the loops run to b.modes): the
/// modes' stored entries, log μ, μ̃, log c_j and each mode's mixed initial condition.
template <class S, int N, int K, class F>
struct CycleMixing {
  using Mode = std::array<S, F::kEntries>;
  using Estimate = std::array<S, F::kCombined>;
  Mode modes[N][K];  // mode j's K packs together: the step takes them as they are
  Estimate mixed[N][K];
  std::array<S, N> log_mu[K], scaled_mu[K], log_c[K];
};

/// The modes' stored entries, log μ and μ̃ of the K packs of lanes from lane `t` into `m`.
template <class S, int N, int K, class F>
[[gnu::always_inline]] inline void load_modes(const CycleBlock& b, int t,
                                              CycleMixing<S, N, K, F>& m) {
  using Slots = CycleSlots<F>;
  constexpr int kLanes = kLanesOf<S>;
  const int n = N == kMaxModes ? b.modes : N;
  for (int k = 0; k < K; ++k) {
    auto st = [&](int j, int entry) { return Slots::at(b, j, entry, t + k * kLanes); };
    for (int i = 0; i < n; ++i) {
      for (int e = 0; e < F::kEntries; ++e) m.modes[i][k][e] = lane_load<S>(st(i, e));
      m.log_mu[k][i] = lane_load<S>(st(i, Slots::kLogMu));
      m.scaled_mu[k][i] = lane_load<S>(st(i, Slots::kScaledMu));
    }
  }
}

/// The mixing (eq. 4–6) of the K packs of lanes from lane `t` (imm_algebra.hpp): predicted mode
/// probabilities c̃_j = Σ_i p_ij μ̃_i with μ̃ = μ / max μ (as ImmEstimator; recomputed from log μ
/// where kLibmProbabilities, else as stored), weights μ_ij = p_ij μ̃_i / c̃_j,
/// log c_j = log c̃_j + max_i log μ_i, and the mixed initial conditions. The state is not changed.
/// `active` is 1 in the lanes whose results count (0: a lane past the tracks stepped, whatever its
/// state: it does not send the pack to the exact fallback).
template <class S, int N, int K, class F>
[[gnu::always_inline]] inline void mix_modes(const F& family, const CycleBlock& b, int t,
                                             const S (&active)[K], CycleMixing<S, N, K, F>& m) {
  using Fn = ProbabilityFunctions<F>;
  const int n = N == kMaxModes ? b.modes : N;
  load_modes(b, t, m);
  std::array<S, N> predicted[K];
  std::array<S, static_cast<std::size_t>(N) * N> weights[K];
  const auto p = [&b, n](int i, int j) { return b.transition[i * n + j]; };
  for (int k = 0; k < K; ++k) {
    S shift;
    if constexpr (kLibmProbabilities<F>) {
      shift = algebra::scaled_probabilities<Fn>(n, m.log_mu[k], m.scaled_mu[k]);
    } else {
      shift = algebra::largest<S>(n, m.log_mu[k]);
    }
    algebra::predict_probabilities<Fn, kDivision<F>>(n, p, m.scaled_mu[k], shift, predicted[k],
                                                     m.log_c[k], weights[k].data());
  }
  for (int k = 0; k < K; ++k) {
    if (algebra::needs_exact_prediction(n, predicted[k], active[k])) [[unlikely]] {
      algebra::exact_prediction(
          n, [&b, n](int i, int j) { return b.log_transition[i * n + j]; }, m.log_mu[k],
          predicted[k], m.log_c[k], weights[k].data());
    }
  }
  for (int j = 0; j < n; ++j) {
    for (int k = 0; k < K; ++k) {
      family.mix(
          n, weights[k].data() + j * n, [&](int i) -> const auto& { return m.modes[i][k]; },
          m.mixed[j][k]);
    }
  }
}

/// Whether family F steps the modes of one track in the lanes of a pack P.
template <class F, class P>
concept StepsAcrossModes = requires(const F& f, const std::array<P, F::kCombined>& mixed,
                                    const std::array<P, F::kEntries>& current,
                                    const typename F::template Plot<double>& z,
                                    std::array<P, F::kEntries>& updated, P& value) {
  f.template steps_across_modes<P>(1, mixed, current, z, updated, value, value);
};

/// The mixing and the modes' steps of one track (N ≤ 8 modes known at compile time) with mode j in
/// lane j of one pack (F::steps_across_modes): per mode the same IEEE operations as mix_modes and
/// F::steps give a double, so the same bits, in one pass over the modes instead of N. Of `m` it
/// fills what the rest of the cycle reads (the modes, log μ, μ̃), not log c_j or the mixed
/// conditions, which go into `centered` and the step. False, with the state untouched, where some
/// c̃_j is not positive (the general path then takes the exact fallback).
template <int N, class F>
[[gnu::always_inline]] inline bool mix_and_step_across_modes(
    const F& family, const CycleBlock& b, int t, const typename F::template Plot<double>& z,
    CycleMixing<double, N, 1, F>& m, std::array<double, F::kEntries> (&updated)[N][1],
    std::array<double, N>& centered, double& outcome) {
  using P = ModePack<N>;
  constexpr int W = kLanesOf<P>;
  // Mode j's value in lane j; the lanes past the modes hold 1 (finite, never read).
  auto in_lanes = [&](auto&& value) {
    double lanes[W];
    for (int j = 0; j < W; ++j) lanes[j] = j < N ? value(j) : 1.0;
    return lane_load<P>(lanes);
  };
  load_modes(b, t, m);
  double shift = -std::numeric_limits<double>::infinity();
  for (int i = 0; i < N; ++i) shift = pick(shift < m.log_mu[0][i], m.log_mu[0][i], shift);
  // c̃_j = Σ_i p_ij μ̃_i in lane j, and the weights μ_ij (row i: lane j's).
  P row[N];
  P predicted = splat<P>(0.0);
  for (int i = 0; i < N; ++i) {
    row[i] = in_lanes([&](int j) { return b.transition[i * N + j]; });
    predicted += row[i] * m.scaled_mu[0][i];
  }
  double c[W];
  lane_store(c, predicted);
  for (int j = 0; j < N; ++j) {
    if (!(c[j] > 0.0)) return false;
  }
  const P inverse = 1.0 / predicted;
  P weights[N];
  for (int i = 0; i < N; ++i) weights[i] = row[i] * m.scaled_mu[0][i] * inverse;
  const P log_c = lane_log(predicted) + shift;
  // Every mode's initial condition, mode j's in lane j, from the modes' entries in every lane.
  std::array<P, F::kEntries> spread[N];
  for (int i = 0; i < N; ++i) {
    for (int e = 0; e < F::kEntries; ++e) spread[i][e] = splat<P>(m.modes[i][0][e]);
  }
  // NOLINTNEXTLINE(cppcoreguidelines-pro-type-member-init): mix fills it
  std::array<P, F::kCombined> mixed;
  family.mix(
      N, weights, [&](int i) -> const auto& { return spread[i]; }, mixed);
  // NOLINTNEXTLINE(cppcoreguidelines-pro-type-member-init): filled below and by the step
  std::array<P, F::kEntries> current, next;
  for (int e = 0; e < F::kEntries; ++e)
    current[e] = in_lanes([&](int j) { return m.modes[j][0][e]; });
  P log_likelihood, code;
  family.template steps_across_modes<P>(N, mixed, current, z, next, log_likelihood, code);

  double lanes[W], codes[W];
  lane_store(lanes, log_likelihood + log_c);
  lane_store(codes, code);
  outcome = kOk;
  for (int j = 0; j < N; ++j) {
    centered[j] = lanes[j];
    outcome = pick(outcome != kOk, outcome, codes[j]);
  }
  for (int e = 0; e < F::kEntries; ++e) {
    lane_store(lanes, next[e]);
    for (int j = 0; j < N; ++j) updated[j][0][e] = lanes[j];
  }
  return true;
}

/// One IMM cycle of the K packs of lanes from lane `t`, with plots `z`, `usable` 1 where a lane's
/// plot is usable and `stepped` 1 where a lane is to step (0: a padding lane). Each lane's code
/// (kOk, kBadPlot, the first failing mode's, kUnderflow, as F::track_code makes it) goes to
/// `code` (K packs); a lane commits its new state where `stepped` and kOk.
template <class S, int N, int K, class F>
[[gnu::always_inline]] inline void imm_cycle(const F& family, const CycleBlock& b, int t,
                                             const typename F::template Plot<S> (&z)[K],
                                             const S (&usable)[K], const S (&stepped)[K],
                                             double* code) {
  using Slots = CycleSlots<F>;
  using Mode = std::array<S, F::kEntries>;
  constexpr int kLanes = kLanesOf<S>;
  const int n = N == kMaxModes ? b.modes : N;
  // NOLINTNEXTLINE(cppcoreguidelines-pro-type-member-init): the mixing fills it
  CycleMixing<S, N, K, F> m;
  Mode updated[N][K];
  std::array<S, N> centered[K];
  S outcome[K];
  bool across_modes = false;
  if constexpr (std::is_same_v<S, double> && K == 1 && N >= 2 && N <= 8 &&
                StepsAcrossModes<F, ModePack<N>> && !kLibmProbabilities<F>) {
    across_modes =
        mix_and_step_across_modes<N>(family, b, t, z[0], m, updated, centered[0], outcome[0]);
  }
  if (!across_modes) {
    mix_modes<S, N, K>(family, b, t, stepped, m);
    if constexpr (requires { family.template record_log_c<S, N, K>(n, m.log_c); })
      family.template record_log_c<S, N, K>(n, m.log_c);
    // Each mode's step, ℓ_j + log c_j; the first mode that fails decides a lane's outcome.
    for (int k = 0; k < K; ++k) outcome[k] = splat<S>(kOk);
    for (int j = 0; j < n; ++j) {
      S log_likelihood[K], mode_code[K];
      family.template steps<S, K>(j, m.mixed[j], m.modes[j], z, updated[j], log_likelihood,
                                  mode_code);
      for (int k = 0; k < K; ++k) {
        centered[k][j] = log_likelihood[k] + m.log_c[k][j];
        outcome[k] = pick(outcome[k] != kOk, outcome[k], mode_code[k]);
      }
    }
  }

  // The posterior in log space (eq. 8–9; imm_algebra.hpp): μ̃_j = exp(ℓ_j − max ℓ),
  // log μ_j = (ℓ_j − max ℓ) − log Σ μ̃, μ_j = μ̃_j / Σ μ̃. A lane that fails computes them too.
  std::array<S, N> scaled[K];
  S top[K], sum[K], log_sum[K];
  for (int k = 0; k < K; ++k) {
    top[k] =
        algebra::posterior<ProbabilityFunctions<F>>(n, centered[k], scaled[k], sum[k], log_sum[k]);
  }

  auto st = [&](int j, int entry, int k) { return Slots::at(b, j, entry, t + k * kLanes); };
  using Commit = decltype(std::declval<S>() == 0.0);
  Commit commit[K];
  std::array<S, N> posterior[K];
  for (int k = 0; k < K; ++k) {
    const S track = family.track_code(lane_outcome(usable[k], outcome[k], top[k]));
    lane_store(code + static_cast<std::ptrdiff_t>(k) * kLanes, track);
    commit[k] = pick(stepped[k] != 0.0, track, kBadPlot) == kOk;
    const S inverse_sum = algebra::inverse_of<kDivision<F>>(sum[k]);
    for (int j = 0; j < n; ++j)
      posterior[k][j] = algebra::divided<kDivision<F>>(scaled[k][j], sum[k], inverse_sum);
  }
  for (int j = 0; j < n; ++j) {
    for (int k = 0; k < K; ++k) {
      lane_store(st(j, Slots::kLogMu, k),
                 pick(commit[k], centered[k][j] - log_sum[k], m.log_mu[k][j]));
      lane_store(st(j, Slots::kScaledMu, k), pick(commit[k], scaled[k][j], m.scaled_mu[k][j]));
      for (int e = 0; e < F::kEntries; ++e)
        lane_store(st(j, e, k), pick(commit[k], updated[j][k][e], m.modes[j][k][e]));
    }
  }
  // The combination (eq. 10–11).
  if constexpr (!kStoresCombined<F>) return;
  for (int k = 0; k < K; ++k) {
    typename CycleMixing<S, N, K, F>::Estimate estimate;
    family.mix(
        n, posterior[k].data(), [&](int i) -> const auto& { return updated[i][k]; }, estimate);
    for (int e = 0; e < F::kCombined; ++e) {
      double* combined = st(n, e, k);
      lane_store(combined, pick(commit[k], estimate[e], lane_load<S>(combined)));
    }
  }
}

/// f(std::integral_constant<int, N>{}) with N = `modes` for the common sizes (their loops
/// unrolled), kMaxModes for any other (the loops then run to the block's mode count); always
/// kMaxModes with IMM_GENERIC_MODE_COUNT (the sanitizer build: cmake/ImmBuildSpeed.cmake).
template <class Fn>
[[gnu::always_inline]] inline void with_mode_count(int modes, Fn&& f) {
#ifdef IMM_GENERIC_MODE_COUNT
  (void)modes;
  return f(std::integral_constant<int, kMaxModes>{});
#else
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
#endif
}

}  // namespace imm::bank

#pragma GCC diagnostic pop
