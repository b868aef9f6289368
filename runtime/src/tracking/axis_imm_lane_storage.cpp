// SPDX-License-Identifier: Apache-2.0
#include "imm/tracking/axis_imm_lane_storage.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "axis_lane_bank.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "initial_state_check.hpp"

namespace imm {

AxisImmLaneStorage::AxisImmLaneStorage(std::string_view name, const Switching& switching,
                                       int entries)
    : LaneStorage(name), modes_(static_cast<int>(switching.initial.size())), entries_(entries) {
  const Eigen::MatrixXd& transition = switching.transition;
  const Eigen::VectorXd& initial = switching.initial;
  for (int i = 0; i < modes_; ++i) {
    for (int j = 0; j < modes_; ++j) {
      transition_.push_back(transition(i, j));
      log_transition_.push_back(safe_log(transition(i, j)));
    }
    initial_log_mu_.push_back(safe_log(initial(i)));
  }
}

void AxisImmLaneStorage::allocate_modes(std::size_t capacity, int block, std::size_t extra) {
  allocate(capacity, 2, block, static_cast<std::size_t>(slots_after_modes()) + extra);
}

ModeVector AxisImmLaneStorage::initial_probabilities() const {
  ModeVector mu(modes_);
  for (int j = 0; j < modes_; ++j) mu(j) = std::exp(initial_log_mu_[static_cast<std::size_t>(j)]);
  return mu;
}

std::ptrdiff_t AxisImmLaneStorage::start_modes(std::size_t track, const GaussianState<4>& state) {
  const std::ptrdiff_t t = checked(track);
  detail::check_initial_state(state);
  const double top = *std::max_element(initial_log_mu_.begin(), initial_log_mu_.end());
  for (int axis = 0; axis < 2; ++axis) {
    const std::ptrdiff_t lane = 2 * t + axis;
    const std::array<double, 5> values = bank::axis_entries(state, axis);
    for (int j = 0; j < modes_; ++j) {
      const double log_mu = initial_log_mu_[static_cast<std::size_t>(j)];
      for (int e = 0; e < entries_; ++e)
        slot(mode_slot(j, e))[lane] = e < 5 ? values[static_cast<std::size_t>(e)] : 0.0;
      slot(mode_slot(j, entries_))[lane] = log_mu;
      slot(mode_slot(j, entries_ + 1))[lane] = std::exp(log_mu - top);
    }
  }
  return t;
}

ModeVector AxisImmLaneStorage::mode_probabilities(std::size_t track) const {
  const std::ptrdiff_t t = checked(track);
  ModeVector mu(2 * modes_);
  for (int axis = 0; axis < 2; ++axis) {
    for (int j = 0; j < modes_; ++j)
      mu(axis * modes_ + j) = std::exp(slot(mode_slot(j, entries_))[2 * t + axis]);
  }
  return mu;
}

}  // namespace imm
