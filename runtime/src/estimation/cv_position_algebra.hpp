// SPDX-License-Identifier: Apache-2.0
#pragma once
// The Kalman algebra of a constant-velocity mode with a Cartesian plot, written out: state
// [x, vx, y, vy], F = [[1, T], [0, 1]] per axis, H selecting [x, y]. A Gaussian is 14 numbers,
// the mean (entries 0–3) and the covariance's upper triangle row by row (4–13), so it is exactly
// symmetric. One track's arithmetic, used by the TrackBank's lanes (track_bank_kernel.cpp) and
// by the one-track CvPositionMode (cv_position_mode.hpp): both compute the same IEEE operations
// in the same order. Not installed.
//
// Entries are read and written through accessors (at(e) returning S&), so a plain array and a
// pack of lanes take the same code: S is the number type, a double for one track or a vector of
// doubles for one lane per track (lane_pack.hpp); the model's constants (T, Q, R) are doubles.
// Everything is inline and branch-free.

#include <cstddef>
#include <type_traits>
#include <utility>

namespace imm::cv_position {

constexpr int kN = 4;
constexpr int kTriangle = 10;
constexpr int kEntries = kN + kTriangle;

// Index of P(a, b) in the stored upper triangle (row by row).
constexpr int sym(int a, int b) {
  return a <= b ? a * kN - a * (a + 1) / 2 + b : b * kN - b * (b + 1) / 2 + a;
}

// f(integral_constant<int, 0>) … f(integral_constant<int, N − 1>), unrolled at compile time so
// that the small per-track arrays become registers.
template <int N, class F>
[[gnu::always_inline]] inline void each(F&& f) {
  [&]<int... I>(std::integer_sequence<int, I...>) { (f(std::integral_constant<int, I>{}), ...); }
  (std::make_integer_sequence<int, N>{});
}

// Prediction in place: x⁻ = F x, P⁻ = F P Fᵀ + Q (q: Q's upper triangle, row by row, q[i] a
// double or an S: one Q for every lane, or each lane its own).
template <class At, class Q>
[[gnu::always_inline]] inline void predict(At&& at, double T, const Q& q) {
  using S = std::remove_cvref_t<decltype(at(0))>;
  S p[kN][kN];
  each<kN>([&](auto a) { each<kN>([&](auto c) { p[a][c] = at(kN + sym(a, c)); }); });
  S fp[kN][kN];  // F P
  each<kN>([&](auto c) {
    fp[0][c] = p[0][c] + T * p[1][c];
    fp[1][c] = p[1][c];
    fp[2][c] = p[2][c] + T * p[3][c];
    fp[3][c] = p[3][c];
  });
  each<kN>([&](auto a) {
    const S row[kN] = {fp[a][0] + T * fp[a][1], fp[a][1], fp[a][2] + T * fp[a][3], fp[a][3]};
    each<kN>([&](auto c) {
      if constexpr (c >= a) at(kN + sym(a, c)) = row[c] + q[sym(a, c)];
    });
  });
  at(0) = at(0) + T * at(1);
  at(2) = at(2) + T * at(3);
}

// What an update reports besides the updated Gaussian. The checks are left to the caller (a
// comparison in the bank's lane loop would keep it scalar): S is positive definite when
// s00 > 0 and det > threshold (Sylvester, with kalman_filter.hpp's relative guard), and the
// result is finite when `finite` is 0 (it sums v − v over every output).
template <class S>
struct UpdateOutcome {
  S nu0{}, nu1{};         // ν = z − H x⁻
  S s00{}, s01{}, s11{};  // S = H P⁻ Hᵀ + R
  S det{};                // |S|
  S mahalanobis{};        // νᵀ S⁻¹ ν
  S threshold{};          // 1e-14 s00 s11
  S finite{};
};

// Joseph-form update (kalman_filter.hpp written out for the position-selecting H) of the
// predicted Gaussian `in` into `out`: S = H P Hᵀ + R, K = P Hᵀ S⁻¹, C = P − K (P Hᵀ)ᵀ,
// P⁺ = C − (C Hᵀ) Kᵀ + K R Kᵀ.
template <class In, class Out, class S = std::remove_cvref_t<std::invoke_result_t<In, int>>>
[[gnu::always_inline]] inline UpdateOutcome<S> update(In&& in, Out&& out, S zx, S zy, double r00,
                                                      double r01, double r11) {
  // Locals, not the struct's fields, inside the unrolled lambdas: a field written through the
  // captured struct keeps it in memory, and the bank's lane loop would stay scalar.
  S p[kN][kN];
  each<kN>([&](auto a) { each<kN>([&](auto c) { p[a][c] = in(kN + sym(a, c)); }); });
  const S s00 = p[0][0] + r00;
  const S s01 = p[0][2] + r01;
  const S s11 = p[2][2] + r11;
  const S det = s00 * s11 - s01 * s01;
  const S inverse_det = 1.0 / det;
  const S i00 = s11 * inverse_det, i01 = -s01 * inverse_det, i11 = s00 * inverse_det;
  S k[kN][2];
  each<kN>([&](auto a) {
    k[a][0] = p[a][0] * i00 + p[a][2] * i01;
    k[a][1] = p[a][0] * i01 + p[a][2] * i11;
  });
  const S nu0 = zx - in(0);
  const S nu1 = zy - in(2);
  S finite{};
  each<kN>([&](auto a) {
    const S mean = in(a) + (k[a][0] * nu0 + k[a][1] * nu1);
    out(a) = mean;
    finite += mean - mean;
  });
  S cc[kN][kN];
  each<kN>([&](auto a) {
    each<kN>([&](auto c) { cc[a][c] = p[a][c] - (k[a][0] * p[c][0] + k[a][1] * p[c][2]); });
  });
  each<kN>([&](auto a) {
    const S kr0 = k[a][0] * r00 + k[a][1] * r01;
    const S kr1 = k[a][0] * r01 + k[a][1] * r11;
    each<kN>([&](auto c) {
      if constexpr (c >= a) {
        const S value = (cc[a][c] - (cc[a][0] * k[c][0] + cc[a][2] * k[c][1])) +
                        (kr0 * k[c][0] + kr1 * k[c][1]);
        out(kN + sym(a, c)) = value;
        finite += value - value;
      }
    });
  });
  UpdateOutcome<S> o;
  o.nu0 = nu0;
  o.nu1 = nu1;
  o.s00 = s00;
  o.s01 = s01;
  o.s11 = s11;
  o.det = det;
  o.mahalanobis = nu0 * (i00 * nu0 + i01 * nu1) + nu1 * (i01 * nu0 + i11 * nu1);
  o.threshold = 1e-14 * s00 * s11;
  o.finite = finite;
  return o;
}

}  // namespace imm::cv_position
