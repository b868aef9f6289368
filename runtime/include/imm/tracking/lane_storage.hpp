// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The storage the banks of the learned kinds share: a structure of arrays of state slots, one
/// lane per track (or per track axis), the lanes padded to whole blocks so that a block's kernel
/// reads and writes whole vectors, and which tracks have been started. InputEstimatorTrackBank
/// derives from it, GaFuzzyTrackBank and FcmImmTrackBank through AxisImmLaneStorage
/// (axis_imm_lane_storage.hpp), WimmTrackBank and FimmTrackBank through TwoModeLaneStorage
/// (two_mode_lane_storage.hpp); what a slot holds is each bank's own.
/// The calls every bank answers are TrackBankCalls' (track_bank_calls.hpp).

#include <cstddef>
#include <string_view>
#include <vector>

#include "imm/core/aligned_allocator.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/track_bank_calls.hpp"

namespace imm {

/// The slot of entry `entry` of IMM mode j in a bank's lanes, where each mode holds `entries`
/// entries followed by its log μ and its μ̃ = μ / max μ: j · (entries + 2) + entry. The layout of
/// the banks' IMM cycle, which the plain IMM's, the GA-fuzzy and the FCM-IMM banks store their
/// modes in; entry = entries and entries + 1 are the mode's log μ and μ̃.
[[nodiscard]] constexpr int imm_mode_slot(int j, int entries, int entry) {
  return j * (entries + 2) + entry;
}

/// Tracks as lanes of a structure of arrays (see the file comment).
class IMM_RUNTIME_EXPORT LaneStorage : public TrackBankCalls {
 protected:
  /// A bank named `name` (in the messages of its refusals).
  explicit LaneStorage(std::string_view name) : TrackBankCalls(name) {}

  /// Room for `capacity` tracks of `lanes_per_track` lanes each, `slots` slots of a lane, the
  /// lanes rounded up to whole blocks of `block` (and to stride()): every slot 0, no track
  /// initialized. Throws InvalidParameter("capacity") for a capacity outside [1, 2^26].
  void allocate(std::size_t capacity, int lanes_per_track, int block, std::size_t slots);

  /// Slot `index`'s first lane; the slots are stride() lanes apart.
  [[nodiscard]] double* slot(int index) { return state_.data() + index * stride_; }
  /// Slot `index`'s first lane.
  [[nodiscard]] const double* slot(int index) const { return state_.data() + index * stride_; }
  /// Lanes per slot: the tracks' lanes rounded up to whole blocks, and to an odd number of
  /// cache lines.
  [[nodiscard]] std::ptrdiff_t stride() const { return stride_; }

 private:
  std::ptrdiff_t stride_ = 0;
  std::vector<double, AlignedAllocator<double>> state_;  // slots × stride, slot 0 on a line
};

}  // namespace imm
