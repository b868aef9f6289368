// SPDX-License-Identifier: Apache-2.0
#pragma once
// The exponential of the batch gradient's sigmoids (batch_gradients.cpp). Not installed.

#include <bit>
#include <cmath>
#include <cstdint>

#include "imm/math/lane_math.hpp"

namespace imm::trainer::mlp {

// eˣ for x ≤ 0 (the sigmoid's e^−|s|) within 2 ulp, the clones' fused multiply-adds doing the
// polynomial: x = n ln 2 + r, |r| ≤ ½ ln 2, eʳ by its Taylor series to r¹³ (truncation below
// 10⁻¹⁷) in Estrin's scheme, 2ⁿ into the exponent; 0 below −708 (where lane_exp underflows too:
// the arithmetic's meaningless number there, every operation defined, is replaced). Half of
// lane_exp's operations: no overflow branch, and one rounding per multiply-add.
[[gnu::always_inline]] inline double exp_nonpositive(double x) {
  constexpr double kLog2e = 1.4426950408889634074;
  constexpr double kLn2High = 6.93147180369123816490e-01;
  constexpr double kLn2Low = 1.90821492927058770002e-10;
  constexpr double kRound = 0x1.8p52;
  const bool underflow = x < -708.0;
  const double shifted = std::fma(x, kLog2e, kRound);
  const double n = shifted - kRound;
  const double r = std::fma(-n, kLn2Low, std::fma(-n, kLn2High, x));
  const double r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
  const double a0 = 1.0 + r, a1 = std::fma(r, 1.0 / 6.0, 1.0 / 2.0);
  const double a2 = std::fma(r, 1.0 / 120.0, 1.0 / 24.0);
  const double a3 = std::fma(r, 1.0 / 5040.0, 1.0 / 720.0);
  const double a4 = std::fma(r, 1.0 / 362880.0, 1.0 / 40320.0);
  const double a5 = std::fma(r, 1.0 / 39916800.0, 1.0 / 3628800.0);
  const double a6 = std::fma(r, 1.0 / 6227020800.0, 1.0 / 479001600.0);
  const double b0 = std::fma(r2, a1, a0), b1 = std::fma(r2, a3, a2), b2 = std::fma(r2, a5, a4);
  const double p = std::fma(r8, std::fma(r4, a6, b2), std::fma(r4, b1, b0));
  // 2ⁿ from shifted's pattern, kRound's plus n: the shift drops kRound's bits (lane_exp).
  const double scale =
      std::bit_cast<double>((std::bit_cast<std::uint64_t>(shifted) + 1023U) << 52U);
  return pick(underflow, 0.0, p * scale);
}

}  // namespace imm::trainer::mlp
