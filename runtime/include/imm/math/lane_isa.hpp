// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The vector instruction set the pack kernels run on (the TrackBank's and the GA-fuzzy bank's
/// IMM cycle): each is compiled three times, for AVX-512 with packs of eight doubles, for AVX2
/// with packs of four and for the baseline with packs of two, so that a pack is one vector of
/// the instruction set that runs it (GCC compiles the comparisons of a wider pack element by
/// element; lane_math.hpp). Every instruction set gives the same bits: a lane's operations do
/// not depend on the pack's width.

#include <array>
#include <cstdint>
#include <string_view>

#include "imm/core/enum_names.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/runtime_export.hpp"

#if IMM_HAS_VECTOR_CLONES
/// Compiles a function for AVX-512 (where GCC can; empty elsewhere): a clone of that set beside the
/// default, which GCC 12 compiles better than a target("avx512f") function (the GA bank took a
/// third more time for code of the same length). Like IMM_VECTOR_CLONES, it must not throw
/// (lane_math.hpp).
#define IMM_TARGET_AVX512 __attribute__((target_clones("avx512f", "default")))
/// Compiles a function for AVX2 (where GCC can; empty elsewhere).
#define IMM_TARGET_AVX2 __attribute__((target_clones("avx2", "default")))
#else
/// Empty: no vector clones here (another compiler or platform).
#define IMM_TARGET_AVX512
/// Empty: no vector clones here (another compiler or platform).
#define IMM_TARGET_AVX2
#endif

/// DEFINE(isa, target, width) for each instruction set: its name (the suffix for_lane_isa's
/// functions take: avx512, avx2, baseline), the attribute that compiles a function for it, and
/// its pack's width (lane_pack_width). A kernel defines its three functions with one DEFINE.
#define IMM_FOR_EACH_LANE_ISA(DEFINE)                                                \
  DEFINE(avx512, IMM_TARGET_AVX512, ::imm::lane_pack_width(::imm::LaneIsa::kAvx512)) \
  DEFINE(avx2, IMM_TARGET_AVX2, ::imm::lane_pack_width(::imm::LaneIsa::kAvx2))       \
  DEFINE(baseline, , ::imm::lane_pack_width(::imm::LaneIsa::kBaseline))

namespace imm {

/// An instruction set of the pack kernels, from the narrowest.
enum class LaneIsa : std::uint8_t {
  kBaseline,  ///< x86-64's SSE2 (or any other CPU): packs of 2
  kAvx2,      ///< AVX2: packs of 4
  kAvx512,    ///< AVX-512F: packs of 8
};

/// Each instruction set with its name (core/enum_names.hpp), as imm-bench's --lane_isa and the
/// benchmark reports spell it.
inline constexpr std::array kLaneIsaNames{EnumName<LaneIsa>{LaneIsa::kAvx512, "avx512"},
                                          EnumName<LaneIsa>{LaneIsa::kAvx2, "avx2"},
                                          EnumName<LaneIsa>{LaneIsa::kBaseline, "baseline"}};

/// The name of an instruction set.
[[nodiscard]] constexpr std::string_view to_string(LaneIsa isa) {
  return name_of(kLaneIsaNames, isa);
}

/// The doubles in a pack of `isa`.
[[nodiscard]] constexpr int lane_pack_width(LaneIsa isa) {
  return isa == LaneIsa::kAvx512 ? 8 : isa == LaneIsa::kAvx2 ? 4 : 2;
}

/// The instruction set the pack kernels run on: the widest this CPU has (kBaseline where the
/// kernels are not compiled for more), at most the cap.
[[nodiscard]] IMM_RUNTIME_EXPORT LaneIsa lane_isa();

/// Caps lane_isa() at `isa` (kAvx512: no cap), so that tests and benchmarks can run the narrower
/// instruction sets on one machine. The results do not depend on it. Not to be changed while a
/// bank steps in another thread.
IMM_RUNTIME_EXPORT void cap_lane_isa(LaneIsa isa);

/// Whether the AVX-512 kernels run (lane_isa()): a kernel bound by the latency of one block's chain
/// of operations takes wider blocks there (its results do not depend on it).
[[nodiscard]] inline bool wide_vector_clones() { return lane_isa() == LaneIsa::kAvx512; }

/// The one of a kernel's three functions (or anything else) for instruction set `isa` (read
/// lane_isa() once per call of the kernel, not once per block).
template <class F>
[[nodiscard]] F for_lane_isa(LaneIsa isa, F avx512, F avx2, F baseline) {
  switch (isa) {
    case LaneIsa::kAvx512:
      return avx512;
    case LaneIsa::kAvx2:
      return avx2;
    default:
      return baseline;
  }
}

}  // namespace imm
