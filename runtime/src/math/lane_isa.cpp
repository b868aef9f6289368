// SPDX-License-Identifier: Apache-2.0
#include "imm/math/lane_isa.hpp"

#include <algorithm>
#include <atomic>

namespace imm {
namespace {

LaneIsa cpu_isa() {
#if IMM_HAS_VECTOR_CLONES
  if (__builtin_cpu_supports("avx512f") != 0) return LaneIsa::kAvx512;
  if (__builtin_cpu_supports("avx2") != 0) return LaneIsa::kAvx2;
#endif
  return LaneIsa::kBaseline;
}

std::atomic<LaneIsa> cap{LaneIsa::kAvx512};

}  // namespace

LaneIsa lane_isa() {
  static const LaneIsa cpu = cpu_isa();
  return std::min(cpu, cap.load(std::memory_order_relaxed));
}

void cap_lane_isa(LaneIsa isa) { cap.store(isa, std::memory_order_relaxed); }

}  // namespace imm
