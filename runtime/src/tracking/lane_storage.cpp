// SPDX-License-Identifier: Apache-2.0
#include "imm/tracking/lane_storage.hpp"

namespace imm {

void LaneStorage::allocate(std::size_t capacity, int lanes_per_track, int block,
                           std::size_t slots) {
  hold_tracks(capacity);
  const auto lanes = static_cast<std::size_t>(lanes_per_track) * capacity;
  const auto whole = static_cast<std::size_t>(block);
  // An odd number of cache lines between slots: consecutive slots of a lane then fall into
  // different sets of the first-level cache. (With a power of two, e.g. 1 024 tracks, a pack's
  // slots 8 or 16 KiB apart all share one set and evict each other.)
  constexpr std::size_t kLine = 64 / sizeof(double);
  std::size_t stride = (lanes + whole - 1) / whole * whole;
  stride = (stride + kLine - 1) / kLine * kLine;
  if (stride / kLine % 2 == 0) stride += kLine;
  stride_ = static_cast<std::ptrdiff_t>(stride);
  state_.assign(slots * static_cast<std::size_t>(stride_), 0.0);
}

}  // namespace imm
