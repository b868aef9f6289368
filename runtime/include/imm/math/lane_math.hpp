// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Element functions for loops over lanes (tracks, trajectories, points) that the compiler
/// vectorizes: plain IEEE arithmetic and integer bit operations, no branches and no library call,
/// so that a loop of them becomes a handful of vector instructions and every instruction set
/// (SSE2, AVX2, AVX-512; never FMA) gives the same bits as the scalar code.
///
/// lane_exp, lane_log and lane_atan2 are not libm's: they are within 2 ulp of the correctly rounded
/// result over their documented ranges (tested against libm), not bit-equal to it. Code whose
/// results must equal the runtime filters' to the bit keeps std::exp and std::log.

#include <bit>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

/// On a function of lane loops: AVX-512 or AVX2 chosen at run time where GCC can (ifunc on x86-64
/// Linux), SSE2 otherwise. The project compiles with -ffp-contract=off, so the AVX-512 clone (where
/// FMA exists) contracts nothing either, and every instruction set computes the same bits.
/// Such a function, and whatever it calls, must not throw: GCC 12 compiles a call through the
/// clones' dispatcher as one that cannot throw, so an exception leaving a clone ends the program
/// (std::terminate) instead of reaching the caller's handler. Check arguments before the call.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define IMM_VECTOR_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
/// 1 where IMM_VECTOR_CLONES makes clones (GCC on x86-64 Linux), 0 where it is empty.
#define IMM_HAS_VECTOR_CLONES 1
#else
#define IMM_VECTOR_CLONES
/// 0: IMM_VECTOR_CLONES is empty here (another compiler or platform).
#define IMM_HAS_VECTOR_CLONES 0
#endif

/// A loop over the W lanes of a block, index l: one vector operation per statement. `omp simd`
/// keeps the compiler from unrolling the iterations into scalar code before it vectorizes them;
/// it is there with OpenMP (the trainer) or in a source built with -fopenmp-simd and
/// IMM_OPENMP_SIMD.
#if defined(_OPENMP) || defined(IMM_OPENMP_SIMD)
#define IMM_LANES _Pragma("omp simd") for (int l = 0; l < W; ++l)
#else
#define IMM_LANES for (int l = 0; l < W; ++l)
#endif

namespace imm {

/// `use` ? a : b by bit masks: a select the vectorizer keeps as one (a `?:` on a stored value
/// becomes a conditional store, which stops it).
[[nodiscard, gnu::always_inline]] inline double pick(bool use, double a, double b) {
  const std::uint64_t mask = std::uint64_t{0} - static_cast<std::uint64_t>(use);
  return std::bit_cast<double>((std::bit_cast<std::uint64_t>(a) & mask) |
                               (std::bit_cast<std::uint64_t>(b) & ~mask));
}

// Passing a 64-byte vector by value: GCC and Clang note that its ABI differs without AVX-512. These
// functions are inline and never cross a library boundary.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"

/// W doubles operated on element by element (the GCC and Clang vector extension; W a power of two):
/// the number type of a pack of lanes, one per track or trajectory, in code templated on its
/// number type (lane_exp, lane_log, the banks' and the GA fitness batch's steps). Arithmetic with a
/// double applies it to every element; comparing two packs gives a LanePackMaskOf<W>, all ones
/// where true.
///
/// Inside a target_clones (IMM_VECTOR_CLONES) or target function GCC 12 compiles two things on
/// packs element by element, with scalar code: the & or | of two comparisons' masks (nest picks,
/// or compare once, instead), and any comparison of a pack wider than the clone's vectors (eight
/// doubles in the AVX2 clone). And a lambda called inside a clone is compiled for the baseline
/// target: dispatch on template arguments outside the clones.
template <int W>
struct LanePackTypes {
  static_assert(W >= 2 && (W & (W - 1)) == 0, "a pack holds a power of two of doubles");
  typedef double Value __attribute__((vector_size(8 * W)));        ///< the doubles
  typedef std::uint64_t Bits __attribute__((vector_size(8 * W)));  ///< their bit patterns
  typedef std::int64_t Mask __attribute__((vector_size(8 * W)));   ///< a comparison's result
};
/// A pack of W doubles.
template <int W>
using LanePackOf = typename LanePackTypes<W>::Value;
/// What comparing two LanePackOf<W> gives.
template <int W>
using LanePackMaskOf = typename LanePackTypes<W>::Mask;

/// The elements of a LanePack.
inline constexpr int kLanePackWidth = 8;
/// Eight doubles: the pack of the track banks (one 512-bit vector).
using LanePack = LanePackOf<kLanePackWidth>;
/// The bit patterns of a LanePack.
using LanePackBits = typename LanePackTypes<kLanePackWidth>::Bits;
/// What comparing two LanePacks gives: all ones where true, 0 where false.
using LanePackMask = LanePackMaskOf<kLanePackWidth>;

/// The number of lanes of a number type: 1 for a double, W for a LanePackOf<W>.
template <class S>
inline constexpr int kLanesOf = static_cast<int>(sizeof(S) / sizeof(double));

/// The bit types of a number type: a double's, or a pack's (element by element).
template <class S>
struct LaneBits {
  typedef std::uint64_t Unsigned __attribute__((vector_size(sizeof(S))));  ///< the bit patterns
  typedef std::int64_t Signed __attribute__((vector_size(sizeof(S))));     ///< signed integers
};
/// A double's bit types.
template <>
struct LaneBits<double> {
  using Unsigned = std::uint64_t;  ///< the bit pattern
  using Signed = std::int64_t;     ///< a signed integer of the same width
};

/// A pack's mask type: what comparing two packs gives (not a double's bool).
template <class M>
concept LaneMask = !std::is_same_v<M, bool> && requires(M m) {
  { m[0] } -> std::convertible_to<std::int64_t>;
};

/// `use` ? a : b element by element; a and b each a pack of the mask's width or a double (the
/// same for every element).
template <LaneMask M, class A, class B>
[[nodiscard, gnu::always_inline]] inline auto pick(M use, A a, B b) {
  using Pack = LanePackOf<kLanesOf<M>>;
  using Bits = typename LaneBits<Pack>::Unsigned;
  const auto mask = std::bit_cast<Bits>(use);
  // x − (+0) is x for every x, −0 included (x + 0 would turn −0 into +0).
  return std::bit_cast<Pack>((std::bit_cast<Bits>(a - Pack{}) & mask) |
                             (std::bit_cast<Bits>(b - Pack{}) & ~mask));
}

/// A number type's value `value`: the double itself, or a pack of it in every element.
template <class S>
[[nodiscard, gnu::always_inline]] inline S splat(double value) {
  if constexpr (std::is_same_v<S, double>) {
    return value;
  } else {
    return value - S{};  // x − (+0) is x, −0 included
  }
}

/// A number type's doubles (kLanesOf\<S\>) read from consecutive memory (unaligned).
template <class S>
[[nodiscard, gnu::always_inline]] inline S lane_load(const double* from) {
  S value;
  std::memcpy(&value, from, sizeof value);
  return value;
}
/// A number type's doubles (kLanesOf\<S\>) written to consecutive memory (unaligned).
template <class S>
[[gnu::always_inline]] inline void lane_store(double* to, const S& value) {
  std::memcpy(to, &value, sizeof value);
}

/// √x element by element (libm's, correctly rounded: the same bits in a pack and alone).
template <class S>
[[nodiscard, gnu::always_inline]] inline S lane_sqrt(S x) {
  if constexpr (std::is_same_v<S, double>) {
    return std::sqrt(x);
  } else {
    // Through an array: GCC vectorizes this loop (with -fno-math-errno), not one over a pack's
    // elements.
    double lanes[kLanesOf<S>];
    lane_store(lanes, x);
    for (double& lane : lanes) lane = std::sqrt(lane);
    return lane_load<S>(lanes);
  }
}

namespace detail {
/// eˣ for x in [−708, 709], with no check: Cody–Waite reduction x = n ln 2 + r, |r| ≤ ½ ln 2, a
/// degree-13 Taylor polynomial of eʳ (truncation below 10⁻¹⁷), and 2ⁿ assembled in the exponent
/// bits. Outside that range (or for ±∞) the result is a meaningless number, which the callers
/// replace; every operation stays defined there (floating-point, and unsigned integers that wrap).
template <class S>
[[nodiscard, gnu::always_inline]] inline S exp_unchecked(S x) {
  using Unsigned = typename LaneBits<S>::Unsigned;
  constexpr double kLog2e = 1.4426950408889634074;
  constexpr double kLn2High = 6.93147180369123816490e-01;  // ln 2 with 32 trailing zero bits
  constexpr double kLn2Low = 1.90821492927058770002e-10;   // ln 2 − kLn2High
  constexpr double kRound = 0x1.8p52;                      // adding it rounds to an integer
  const S shifted = x * kLog2e + kRound;
  const S n = shifted - kRound;
  const S r = (x - n * kLn2High) - n * kLn2Low;
  // eʳ = Σ rᵏ/k!, k ≤ 13, by Estrin's scheme: pairs, then pairs of pairs, so that the longest
  // chain of dependent operations is 8 long instead of Horner's 26 (the loops that call this are
  // bound by that latency, not by the operation count).
  const S r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
  const S a0 = 1.0 + r, a1 = 1.0 / 2.0 + r * (1.0 / 6.0);
  const S a2 = 1.0 / 24.0 + r * (1.0 / 120.0), a3 = 1.0 / 720.0 + r * (1.0 / 5040.0);
  const S a4 = 1.0 / 40320.0 + r * (1.0 / 362880.0);
  const S a5 = 1.0 / 3628800.0 + r * (1.0 / 39916800.0);
  const S a6 = 1.0 / 479001600.0 + r * (1.0 / 6227020800.0);
  const S b0 = a0 + r2 * a1, b1 = a2 + r2 * a3, b2 = a4 + r2 * a5;
  const S p = (b0 + r4 * b1) + r8 * (b2 + r4 * a6);
  // n in [−1022, 1023] sits in the low bits of `shifted`'s pattern, which is kRound's plus n; the
  // shift by 52 drops kRound's bits (none of them lies below bit 12), leaving 2ⁿ's exponent field.
  const S scale = std::bit_cast<S>((std::bit_cast<Unsigned>(shifted) + 1023U) << 52U);
  return p * scale;
}
}  // namespace detail

/// eˣ within 2 ulp for x in [−708, 709]; 0 below −708 (libm's subnormal results are flushed),
/// +∞ above 709, NaN for NaN (detail::exp_unchecked says how).
/// S: double, or LanePack (element by element, the same bits as the double).
template <class S>
[[nodiscard, gnu::always_inline]] inline S lane_exp(S x) {
  // NaN: both comparisons are false, and NaN propagates through the arithmetic.
  const auto underflow = x < -708.0;
  const auto overflow = x > 709.0;
  const S result = detail::exp_unchecked(x);
  return pick(underflow, 0.0, pick(overflow, std::numeric_limits<double>::infinity(), result));
}

/// lane_exp(x) to the bit for every x ≤ 709 and NaN, without lane_exp's overflow check: for an
/// exponent that cannot pass 709, such as a difference from a maximum (x − max x) or a negated
/// sum of squares. Above 709 it gives a wrong number, not +∞.
template <class S>
[[nodiscard, gnu::always_inline]] inline S lane_exp_no_overflow(S x) {
  const auto underflow = x < -708.0;
  return pick(underflow, 0.0, detail::exp_unchecked(x));
}

/// ln x within 2 ulp for every positive x, subnormal ones included; −∞ for 0, +∞ for +∞, NaN for
/// a negative x or NaN. x = m 2ᵉ with m in [√½, √2), ln m = 2 atanh f with f = (m − 1)/(m + 1),
/// |f| ≤ 0.172, by its odd series to f²¹ (truncation below 10⁻¹⁸).
/// S: double, or LanePack (element by element, the same bits as the double).
template <class S>
[[nodiscard, gnu::always_inline]] inline S lane_log(S x) {
  using Unsigned = typename LaneBits<S>::Unsigned;
  constexpr double kLn2High = 6.93147180369123816490e-01;
  constexpr double kLn2Low = 1.90821492927058770002e-10;
  constexpr double kSqrtHalf = 0.70710678118654752440;
  const auto subnormal = x < std::numeric_limits<double>::min();
  const S scaled = pick(subnormal, x * 0x1p54, x);
  const auto bits = std::bit_cast<Unsigned>(scaled);
  // The biased exponent as a double (the 2⁵² trick: an integer below 2⁵² in the low mantissa).
  const S biased = std::bit_cast<S>(((bits >> 52U) & 0x7ffU) | 0x4330000000000000ULL) - 0x1p52;
  const S m1 = std::bit_cast<S>((bits & 0x000fffffffffffffULL) | 0x3ff0000000000000ULL);
  // m in [1, 2) → [√½, √2): halve it (exactly) above √2 and count one more in the exponent.
  const auto high = m1 > 2.0 * kSqrtHalf;
  const S m = pick(high, m1 * 0.5, m1);
  const S e = biased - 1023.0 + pick(high, 1.0, 0.0) - pick(subnormal, 54.0, 0.0);
  const S f = (m - 1.0) / (m + 1.0);
  const S f2 = f * f;
  // Σ f²ᵏ/(2k + 1), k ≤ 10, by Estrin's scheme (see lane_exp).
  const S f4 = f2 * f2, f8 = f4 * f4;
  const S t0 = 1.0 / 3.0 + f2 * (1.0 / 5.0), t1 = 1.0 / 7.0 + f2 * (1.0 / 9.0);
  const S t2 = 1.0 / 11.0 + f2 * (1.0 / 13.0), t3 = 1.0 / 15.0 + f2 * (1.0 / 17.0);
  const S t4 = 1.0 / 19.0 + f2 * (1.0 / 21.0);
  const S s = (t0 + f4 * t1) + f8 * ((t2 + f4 * t3) + f8 * t4);
  const S log_m = 2.0 * f + 2.0 * f * (f2 * s);
  const S result = e * kLn2High + (log_m + e * kLn2Low);
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const S special =
      pick(x == 0.0, -kInf, pick(x == kInf, kInf, std::numeric_limits<double>::quiet_NaN()));
  // Nested picks rather than a mask of two comparisons: GCC 12 turns the & of two pack
  // comparisons into element-by-element scalar code inside a target_clones function.
  return pick(x > 0.0, pick(x < kInf, result, special), special);
}

#pragma GCC diagnostic pop

/// atan2(y, x) within 2 ulp of libm's (tested) for finite (y, x) not both 0 (both 0 gives ±0 or ±π
/// with y's and x's signs, as libm); NaN for a NaN. The ratio t = min(|x|, |y|) / max(|x|, |y|) in
/// [0, 1], reduced by atan t = π/4 + atan((t − 1)/(t + 1)) above 0.66, then Cephes's rational
/// approximation of atan on [−0.2, 0.66] (Moshier's atan.c, with its extra bits of π/4); then
/// π/2 ∓ a where |y| > |x|, π − a where x < 0 (−0 included), and y's sign.
[[nodiscard]] inline double lane_atan2(double y, double x) {
  constexpr double kPi = 3.14159265358979323846;
  constexpr double kPiOver2 = 1.57079632679489661923, kPiOver4 = 0.78539816339744830962;
  constexpr double kMoreBits = 6.123233995736765886130e-17;  // π/2 − kPiOver2
  const std::uint64_t y_bits = std::bit_cast<std::uint64_t>(y);
  const std::uint64_t x_bits = std::bit_cast<std::uint64_t>(x);
  const double ay = std::bit_cast<double>(y_bits & 0x7fffffffffffffffULL);
  const double ax = std::bit_cast<double>(x_bits & 0x7fffffffffffffffULL);
  const bool steep = ay > ax;
  const double big = pick(steep, ay, ax), small = pick(steep, ax, ay);
  const double t = pick(big > 0.0, small / big, 0.0);
  const bool high = t > 0.66;
  const double u = pick(high, (t - 1.0) / (t + 1.0), t);
  const double z = u * u;
  const double p = ((((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z -
                      7.500855792314704667340e1) *
                         z -
                     1.228866684490136173410e2) *
                        z -
                    6.485021904942025371773e1);
  const double q = (((((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z +
                      4.328810604912902668951e2) *
                         z +
                     4.853903996359136964868e2) *
                        z +
                    1.945506571482613964425e2);
  const double r = u + u * (z * p / q);
  const double a = pick(high, kPiOver4 + (r + 0.5 * kMoreBits), r);  // atan t, in [0, π/4]
  // The angle from the positive x axis: a, π/2 ∓ a or π − a, each with its constant's lost bits.
  const bool negative_x = (x_bits >> 63U) != 0;
  const double base = pick(steep, kPiOver2, pick(negative_x, kPi, 0.0));
  const double extra = pick(steep, kMoreBits, pick(negative_x, 2.0 * kMoreBits, 0.0));
  const double quadrant = (base + pick(steep != negative_x, -a, a)) + extra;
  const double result = std::bit_cast<double>(std::bit_cast<std::uint64_t>(quadrant) |
                                              (y_bits & 0x8000000000000000ULL));
  return pick((x == x) & (y == y), result, std::numeric_limits<double>::quiet_NaN());
}

}  // namespace imm
