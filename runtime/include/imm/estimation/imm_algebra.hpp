// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The IMM's own arithmetic (Blom & Bar-Shalom; seed 000 eq. 4–11), written once over a number
/// type S — a double for one track (ImmEstimator), a pack of lanes (lane_math.hpp) for one track
/// per element (the banks' IMM cycle, the families' mixes, the NIS and gating collapses). What a
/// mode holds and how it steps is the family's; what is here is the same for every family:
///   - scaled_probabilities, predicted_scaled, mixing_weights (predict_probabilities for all
///     modes at once): the predicted mode probabilities c_j = Σ_i p_ij μ_i and the mixing weights
///     μ_ij = p_ij μ_i / c_j (eq. 6), through μ̃ = μ / max μ, with exact_log_prediction and
///     exact_mixing_weight (exact_prediction for packs) for a c̃_j that underflowed to zero;
///   - posterior: the mode probabilities after the modes' updates (eq. 8–9) in log space;
///   - normalized: weights exp(v_j) / Σ exp(v_k) from log-weights;
///   - collapse: a Gaussian mixture collapsed to its two moments (eq. 4–5 and 10–11). ImmEstimator
///     keeps Eigen's form of it: over a double this one is scalar code, where Eigen sums the same
///     entries two at a time (W1's step 15 % slower on it; docs/performance.md).
///
/// Every statement is the same IEEE operation for a double and for each element of a pack (the
/// project compiles with -ffp-contract=off), so a lane gives the same bits in a pack and alone. A
/// policy says which exp and log the mode probabilities take (LibmFunctions: libm's, as
/// ImmEstimator; LaneFunctions: lane_exp and lane_log, branch-free) and whether a weight divides
/// by its sum or multiplies by the sum's inverse (Division): a bank that must give its one-track
/// filter's bits takes LibmFunctions and Division::kDivide. A detail of the runtime, installed
/// because ImmEstimator's header uses it; not an interface of its own.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <type_traits>
#include <utility>

#include "imm/math/lane_math.hpp"

namespace imm::algebra {

/// The lanes of a value, as doubles (for the few decisions taken lane by lane).
template <class S>
using Lanes = std::array<double, kLanesOf<S>>;
/// A value's lanes.
template <class S>
[[nodiscard, gnu::always_inline]] inline Lanes<S> lanes_of(const S& value) {
  Lanes<S> out;
  lane_store(out.data(), value);
  return out;
}
/// The value of the given lanes.
template <class S>
[[nodiscard, gnu::always_inline]] inline S from_lanes(const Lanes<S>& lanes) {
  return lane_load<S>(lanes.data());
}

/// Whether LaneFunctions' exp_each and log_each take the values of `Values` through one pack:
/// one track's (a double's) values of 2 … 8 modes.
template <class Values>
inline constexpr bool kPacksModes = false;
template <std::size_t N>
inline constexpr bool kPacksModes<std::array<double, N>> = N >= 2 && N <= 8;

/// libm's exp and log, lane by lane: ImmEstimator's mode probabilities, and a bank's that must
/// give its one-track filter's bits.
struct LibmFunctions {
  /// Whether exp_each of `Values` is exp of each value in turn (posterior() then takes them in
  /// the loop that makes them): always.
  template <class Values>
  static constexpr bool kValueByValue = true;
  /// eˣ of every lane.
  template <class S>
  [[nodiscard, gnu::always_inline]] static S exp(S x) {
    return each(x, [](double v) { return v == 0.0 ? 1.0 : std::exp(v); });
  }
  /// log x of every lane.
  template <class S>
  [[nodiscard, gnu::always_inline]] static S log(S x) {
    return each(x, [](double v) { return std::log(v); });
  }
  /// exp of the first n values.
  template <class S, std::size_t N>
  [[gnu::always_inline]] static void exp_each(std::array<S, N>& v, int n) {
    for (int j = 0; j < n; ++j) v[j] = exp(v[j]);
  }
  /// log of the first n values.
  template <class S, std::size_t N>
  [[gnu::always_inline]] static void log_each(std::array<S, N>& v, int n) {
    for (int j = 0; j < n; ++j) v[j] = log(v[j]);
  }

 private:
  template <class S, class F>
  [[gnu::always_inline]] static S each(S x, F&& f) {
    if constexpr (std::is_same_v<S, double>) {
      return f(x);
    } else {
      Lanes<S> lanes = lanes_of(x);
      for (double& lane : lanes) lane = f(lane);
      return from_lanes<S>(lanes);
    }
  }
};

/// lane_exp and lane_log (within 2 ulp of libm's; branch-free): a bank's mode probabilities. For
/// one track (S a double) the values of N ≤ 8 modes go through one pack together: one evaluation
/// of the function instead of N, each value the same bits as alone. Every exponent the algebra
/// takes is below 709 (a difference from a maximum, or log c_j ≤ log 8), so exp is
/// lane_exp_no_overflow: lane_exp's bits without its overflow check.
struct LaneFunctions {
  /// Whether exp_each of `Values` is exp of each value in turn: not for one track's N = 2 … 8
  /// modes' values, which go through one pack together (ModePack).
  template <class Values>
  static constexpr bool kValueByValue = !kPacksModes<Values>;
  /// lane_exp of every lane (an exponent ≤ 709).
  template <class S>
  [[nodiscard, gnu::always_inline]] static S exp(S x) {
    return lane_exp_no_overflow(x);
  }
  /// lane_log of every lane.
  template <class S>
  [[nodiscard, gnu::always_inline]] static S log(S x) {
    return lane_log(x);
  }
  /// lane_exp of the first n values (each ≤ 709).
  template <class S, std::size_t N>
  [[gnu::always_inline]] static void exp_each(std::array<S, N>& v, int n) {
    each<false>(v, n);
  }
  /// lane_log of the first n values.
  template <class S, std::size_t N>
  [[gnu::always_inline]] static void log_each(std::array<S, N>& v, int n) {
    each<true>(v, n);
  }

  /// The pack that holds one lane per mode of N ≤ 8 modes: 2, 4 or 8 lanes.
  template <std::size_t N>
  using ModePack = LanePackOf<(N <= 2   ? 2
                               : N <= 4 ? 4
                                        : 8)>;

 private:
  template <bool kLog, class S, std::size_t N>
  [[gnu::always_inline]] static void each(std::array<S, N>& v, int n) {
    if constexpr (kPacksModes<std::array<S, N>>) {
      using Pack = ModePack<N>;
      constexpr int W = kLanesOf<Pack>;
      // The lanes past the modes hold 1: a finite value for both functions.
      double lanes[W];
      for (int j = 0; j < W; ++j) lanes[j] = j < static_cast<int>(N) ? v[j] : 1.0;
      Pack pack = lane_load<Pack>(lanes);
      pack = kLog ? lane_log(pack) : lane_exp_no_overflow(pack);
      lane_store(lanes, pack);
      for (std::size_t j = 0; j < N; ++j) v[j] = lanes[j];
    } else {
      for (int j = 0; j < n; ++j) v[j] = kLog ? lane_log(v[j]) : lane_exp_no_overflow(v[j]);
    }
  }
};

/// How a weight w_i = a_i / Σ is formed: a_i / Σ (ImmEstimator's), or a_i · (1 / Σ) (one division
/// per sum instead of one per weight).
enum class Division { kDivide, kInverse };

/// a / sum, or a · inverse where `inverse` = 1 / sum.
template <Division kDivision, class S>
[[nodiscard, gnu::always_inline]] inline S divided(S a, S sum, S inverse) {
  if constexpr (kDivision == Division::kDivide) {
    return a / sum;
  } else {
    (void)sum;
    return a * inverse;
  }
}
/// 1 / sum where kDivision needs it (kInverse); anything otherwise.
template <Division kDivision, class S>
[[nodiscard, gnu::always_inline]] inline S inverse_of(S sum) {
  if constexpr (kDivision == Division::kInverse) {
    return 1.0 / sum;
  } else {
    return sum;
  }
}

/// max_j value(j) of the first n values, from −∞: a NaN is passed over.
template <class S, class Value>
[[nodiscard, gnu::always_inline]] inline S largest_of(int n, Value&& value) {
  S top = splat<S>(-std::numeric_limits<double>::infinity());
  for (int j = 0; j < n; ++j) {
    const S v = value(j);
    // A double's max in a register (maxsd); pick's masks through integer registers are a chain
    // of several operations per mode.
    if constexpr (std::is_same_v<S, double>) {
      top = top < v ? v : top;
    } else {
      top = pick(top < v, v, top);
    }
  }
  return top;
}
/// max_j v_j of the first n entries of v.
template <class S, class V>
[[nodiscard, gnu::always_inline]] inline S largest(int n, const V& v) {
  return largest_of<S>(n, [&v](int j) { return v[j]; });
}

/// μ̃_i = exp(log μ_i − shift) of the n modes, with shift = max_i log μ_i (returned): μ scaled by
/// its largest entry, exact, one exponential per mode.
template <class Fn, class LogMu, class Scaled,
          class S = std::remove_cvref_t<decltype(std::declval<Scaled&>()[0])>>
[[gnu::always_inline]] inline S scaled_probabilities(int n, const LogMu& log_mu, Scaled& scaled) {
  const S shift = largest<S>(n, log_mu);
  for (int i = 0; i < n; ++i) scaled[i] = Fn::exp(S(log_mu[i] - shift));
  return shift;
}

/// c̃_j = Σ_i p_ij μ̃_i (eq. 8's inner sum, scaled by max μ) of mode j among n, from μ̃ = μ / max μ
/// (`scaled`, indexed scaled[i]) and Π (p(i, j) = p_ij).
template <class P, class Scaled, class S = std::remove_cvref_t<decltype(std::declval<Scaled>()[0])>>
[[nodiscard, gnu::always_inline]] inline S predicted_scaled(int n, int j, P&& p,
                                                            const Scaled& scaled) {
  S c = splat<S>(0.0);
  for (int i = 0; i < n; ++i) c += p(i, j) * scaled[i];
  return c;
}

/// Mode j's mixing weights μ_ij = p_ij μ̃_i / c̃_j (eq. 6) into w(i), from its c̃_j
/// (predicted_scaled); right where c̃_j > 0.
template <Division kDivision, class S, class P, class Scaled, class W>
[[gnu::always_inline]] inline void mixing_weights(int n, int j, P&& p, const Scaled& scaled, S c,
                                                  W&& w) {
  const S inverse = inverse_of<kDivision>(c);
  for (int i = 0; i < n; ++i) w(i) = divided<kDivision>(S(p(i, j) * scaled[i]), c, inverse);
}

/// The predicted mode probabilities and the mixing weights (eq. 6 and 8's inner sum) of n modes
/// from μ̃ = μ / max μ (`scaled`, with `shift` = max log μ) and Π (p(i, j) = p_ij): the scaled
/// c̃_j = Σ_i p_ij μ̃_i (`predicted`), log c_j = log c̃_j + shift and μ_ij = p_ij μ̃_i / c̃_j
/// (weights[j · n + i]). Where a c̃_j is not positive (an underflow, possible only with zero
/// transition entries) log c_j and the weights are wrong: exact_prediction repairs them.
template <class Fn, Division kDivision, class S, std::size_t N, class P>
[[gnu::always_inline]] inline void predict_probabilities(int n, P&& p,
                                                         const std::array<S, N>& scaled, S shift,
                                                         std::array<S, N>& predicted,
                                                         std::array<S, N>& log_c, S* weights) {
  for (int j = 0; j < n; ++j) {
    const S c = predicted_scaled(n, j, p, scaled);
    predicted[j] = c;
    mixing_weights<kDivision>(n, j, p, scaled, c, [&](int i) -> S& { return weights[j * n + i]; });
  }
  log_c = predicted;
  Fn::log_each(log_c, n);
  for (int j = 0; j < n; ++j) log_c[j] += shift;
}

/// Whether a lane of predict_probabilities' c̃ needs exact_prediction: some c̃_j not positive in a
/// lane where `active` is not 0 (a lane whose result is not read does not count).
template <class S, std::size_t N>
[[nodiscard, gnu::always_inline]] inline bool needs_exact_prediction(
    int n, const std::array<S, N>& predicted, S active = splat<S>(1.0)) {
  S bad = splat<S>(0.0);
  for (int j = 0; j < n; ++j) bad += pick(predicted[j] > 0.0, splat<S>(0.0), active);
  const Lanes<S> lanes = lanes_of(bad);
  return std::any_of(lanes.begin(), lanes.end(), [](double v) { return v != 0.0; });
}

/// log c_j = log Σ_i exp(log p_ij + log μ_i) of mode j among n, exact (a log-sum-exp), for a c̃_j
/// that underflowed (log_p(i, j) = log p_ij, log_mu(i) = log μ_i): −∞ where mode j cannot be
/// reached.
template <class LogP, class LogMu>
[[nodiscard]] double exact_log_prediction(int n, int j, LogP&& log_p, LogMu&& log_mu) {
  double top = -std::numeric_limits<double>::infinity();
  for (int i = 0; i < n; ++i) top = std::max(top, log_p(i, j) + log_mu(i));
  if (!std::isfinite(top)) return top;
  double sum = 0.0;
  for (int i = 0; i < n; ++i) sum += std::exp(log_p(i, j) + log_mu(i) - top);
  // sum ≥ 1: the largest term is exp(0).
  return top + std::log(sum);  // cppcheck-suppress invalidFunctionArg
}

/// Mode j's mixing weight from mode i by its exact log c_j (exact_log_prediction):
/// exp(log p_ij + log μ_i − log c_j), and δ_ij where mode j cannot be reached (log c_j = −∞), so
/// that it keeps its own estimate as its initial condition.
[[nodiscard]] inline double exact_mixing_weight(int i, int j, double log_p, double log_mu,
                                                double log_c) {
  return !std::isfinite(log_c) ? (i == j ? 1.0 : 0.0) : std::exp(log_p + log_mu - log_c);
}

/// Where predict_probabilities' c̃_j is not positive, lane by lane: log c_j by
/// exact_log_prediction and the weights by exact_mixing_weight (log_p(i, j) = log p_ij).
template <class S, std::size_t N, class LogP, class LogMu>
[[gnu::noinline, gnu::cold]] void exact_prediction(int n, LogP&& log_p, const LogMu& log_mu,
                                                   const std::array<S, N>& predicted,
                                                   std::array<S, N>& log_c, S* weights) {
  for (int j = 0; j < n; ++j) {
    const Lanes<S> c = lanes_of(predicted[j]);
    if (std::none_of(c.begin(), c.end(), [](double v) { return !(v > 0.0); })) continue;
    Lanes<S> out = lanes_of(log_c[j]);
    std::array<Lanes<S>, N> mu{}, w{};  // n ≤ N
    for (int i = 0; i < n; ++i) {
      mu[i] = lanes_of(S(log_mu[i]));
      w[i] = lanes_of(weights[j * n + i]);
    }
    for (std::size_t l = 0; l < c.size(); ++l) {
      if (c[l] > 0.0) continue;
      out[l] = exact_log_prediction(n, j, log_p, [&](int i) { return mu[i][l]; });
      for (int i = 0; i < n; ++i) {
        w[i][l] = exact_mixing_weight(i, j, log_p(i, j), mu[i][l], out[l]);
      }
    }
    log_c[j] = from_lanes<S>(out);
    for (int i = 0; i < n; ++i) weights[j * n + i] = from_lanes<S>(w[i]);
  }
}

/// The posterior mode probabilities (eq. 8–9) in log space from the n values v_j = ℓ_j + log c_j
/// (ℓ_j the modes' log-likelihoods; values[j]): top = max_j v_j (returned; not finite where every
/// likelihood underflowed), v_j − top in `centered`, μ̃_j = exp(v_j − top) in `scaled`, their sum
/// Σ ≥ 1 and log Σ. Then log μ_j = centered_j − log Σ, in that order (with ℓ far from zero,
/// top + log Σ would round to top and give two modes log μ = 0), and μ_j = μ̃_j / Σ. `values` may
/// be `centered` itself.
template <class Fn, class S, class Values, class Centered, class Scaled>
[[gnu::always_inline]] inline S posterior(int n, const Values& values, Centered& centered,
                                          Scaled& scaled, S& sum, S& log_sum) {
  const S top = largest<S>(n, values);
  sum = splat<S>(0.0);
  if constexpr (Fn::template kValueByValue<Scaled>) {
    for (int j = 0; j < n; ++j) {
      centered[j] = values[j] - top;
      scaled[j] = Fn::exp(S(centered[j]));
      sum += scaled[j];
    }
  } else {
    for (int j = 0; j < n; ++j) {
      centered[j] = values[j] - top;
      scaled[j] = centered[j];
    }
    Fn::exp_each(scaled, n);
    for (int j = 0; j < n; ++j) sum += scaled[j];
  }
  log_sum = Fn::log(sum);
  return top;
}

/// posterior() of the values in `centered`, which it replaces by v_j − top.
template <class Fn, class S, std::size_t N>
[[gnu::always_inline]] inline S posterior(int n, std::array<S, N>& centered,
                                          std::array<S, N>& scaled, S& sum, S& log_sum) {
  return posterior<Fn>(n, centered, centered, scaled, sum, log_sum);
}

/// log Σ_j exp(v_j) of the first n entries of v (a Gaussian mixture's log-density from its
/// components' log-weighted densities): top + log Σ_j exp(v_j − top), top = max_j v_j, and −∞
/// where every v_j is −∞.
template <class Fn, class S, std::size_t N>
[[nodiscard, gnu::always_inline]] inline S log_sum_exp(int n, const std::array<S, N>& v) {
  const S top = largest<S>(n, v);
  S sum = splat<S>(0.0);
  for (int j = 0; j < n; ++j) sum += Fn::exp(S(v[j] - top));
  return pick(top == -std::numeric_limits<double>::infinity(), top, S(top + Fn::log(sum)));
}

/// c_j = exp(v_j − max v) / Σ_k exp(v_k − max v) of the n log-weights v_j = log_weight(j), into
/// `c` (c[j] = …).
template <class Fn, class S, class LogWeight, class Out>
[[gnu::always_inline]] inline void normalized(int n, LogWeight&& log_weight, Out&& c) {
  const S top = largest_of<S>(n, log_weight);
  S total = splat<S>(0.0);
  for (int j = 0; j < n; ++j) {
    c[j] = Fn::exp(S(log_weight(j) - top));
    total += c[j];
  }
  for (int j = 0; j < n; ++j) c[j] = c[j] / total;
}

/// A component's term of collapse()'s sums: `value`, or 0 where its weight w is 0 (a double's
/// caller has skipped it already).
template <class S>
[[nodiscard, gnu::always_inline]] inline S weighted_term(const S& w, const S& value) {
  if constexpr (std::is_same_v<S, double>) {
    return value;
  } else {
    return pick(w == 0.0, 0.0, value);
  }
}

/// Which entries of a covariance collapse() reads and writes: (a, c) with a ≤ c, or all of them
/// (where the components' covariances are not known to be exactly symmetric).
enum class Entries { kUpper, kAll };

/// Σ_i w_i N(m_i, P_i) over n components collapsed to one Gaussian N(m, P) of dimension D (eq. 4–5
/// and 10–11): m = Σ_i w_i m_i and P = Σ_i w_i (P_i + (m_i − m)(m_i − m)ᵀ), each entry's sum over
/// i = 0, 1, … from +0, a zero weight adding nothing (its component may hold anything; for finite
/// components the same bits as adding its ±0). weight(i), mean(i, a) and covariance(i, a, c) read
/// the components; out_mean(a) and out_covariance(a, c) receive the result. kEntries: the
/// covariances' upper triangle (a ≤ c; P is then symmetric by construction) or every entry.
template <int D, class S, Entries kEntries = Entries::kUpper, class Weight, class Mean,
          class Covariance, class OutMean, class OutCovariance>
[[gnu::always_inline]] inline void collapse(int n, Weight&& weight, Mean&& mean,
                                            Covariance&& covariance, OutMean&& out_mean,
                                            OutCovariance&& out_covariance) {
  constexpr int kCount = kEntries == Entries::kUpper ? D * (D + 1) / 2 : D * D;
  auto last = [](int c) { return kEntries == Entries::kUpper ? c : D - 1; };
  S m[D];
  for (int a = 0; a < D; ++a) m[a] = splat<S>(0.0);
  // One track (S a double) skips a zero weight with a branch, a pack of lanes with a select.
  constexpr bool kBranches = std::is_same_v<S, double>;
  for (int i = 0; i < n; ++i) {
    const S w = weight(i);
    if constexpr (kBranches) {
      if (w == 0.0) continue;
    }
    for (int a = 0; a < D; ++a) m[a] += weighted_term(w, w * mean(i, a));
  }
  S p[kCount];
  for (int k = 0; k < kCount; ++k) p[k] = splat<S>(0.0);
  for (int i = 0; i < n; ++i) {
    const S w = weight(i);
    if constexpr (kBranches) {
      if (w == 0.0) continue;
    }
    S d[D];
    for (int a = 0; a < D; ++a) d[a] = mean(i, a) - m[a];
    // Column by column, (a, c) for a ≤ last(c): a column-major matrix's order.
    int k = 0;
    for (int c = 0; c < D; ++c) {
      for (int a = 0; a <= last(c); ++a, ++k) {
        // cppcheck-suppress uninitvar ; d[0 … D) is written above
        p[k] += weighted_term(w, w * (covariance(i, a, c) + d[a] * d[c]));
      }
    }
  }
  for (int a = 0; a < D; ++a) out_mean(a) = m[a];
  int k = 0;
  for (int c = 0; c < D; ++c) {
    for (int a = 0; a <= last(c); ++a, ++k) out_covariance(a, c) = p[k];
  }
}

}  // namespace imm::algebra
