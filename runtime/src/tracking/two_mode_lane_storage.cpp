// SPDX-License-Identifier: Apache-2.0
#include "imm/tracking/two_mode_lane_storage.hpp"

#include <array>

#include "two_mode_lanes.hpp"

namespace imm {
namespace {

constexpr bank::ModeSlots slots_of(const TwoModeLaneStorage::ModeLayout& mode) {
  return {mode.axis_states, mode.mean, mode.covariance};
}

}  // namespace

GaussianState<6> TwoModeLaneStorage::estimate(std::size_t track) const {
  const std::ptrdiff_t t = checked(track);
  return bank::combined_estimate([&](int entry) { return slot(entry); },
                                 {slots_of(first_), slots_of(second_)}, log_mu_, t);
}

ModeVector TwoModeLaneStorage::mode_probabilities(std::size_t track) const {
  return bank::mode_probabilities([&](int entry) { return slot(entry); }, log_mu_, checked(track));
}

std::ptrdiff_t TwoModeLaneStorage::start(std::size_t track, const GaussianState<6>& state,
                                         const Eigen::Vector2d& initial) {
  const std::ptrdiff_t t = checked(track);
  bank::start_track([&](int entry) { return slot(entry); }, {slots_of(first_), slots_of(second_)},
                    log_mu_, t, state, initial);
  return t;
}

}  // namespace imm
