// SPDX-License-Identifier: Apache-2.0
#include "imm/tracking/lane_storage.hpp"

#include "bank_checks.hpp"

namespace imm {

void LaneStorage::allocate(std::size_t capacity, int lanes_per_track, int block,
                           std::size_t slots) {
  bank::require_capacity(capacity);
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
  initialized_.assign(capacity, 0);
}

bool LaneStorage::initialized(std::size_t track) const {
  return initialized_[static_cast<std::size_t>(checked(track))] != 0;
}

std::ptrdiff_t LaneStorage::checked(std::size_t track) const {
  return static_cast<std::ptrdiff_t>(bank::checked_track(track, capacity()));
}

void LaneStorage::check_step(std::string_view name, std::size_t plots, std::size_t statuses) const {
  bank::check_step(name, plots, statuses, initialized_);
}

void LaneStorage::check_candidates(std::string_view name, std::size_t plots, double gate,
                                   std::ptrdiff_t rows, std::ptrdiff_t cols) const {
  bank::check_candidates(name, plots, gate, rows, cols, initialized_);
}

void LaneStorage::step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status) {
  check_step(name_, plots.size(), status.size());
  step_lanes(plots, status, nullptr);
}

void LaneStorage::step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status,
                       std::span<double> nis) {
  bank::check_nis(name_, plots.size(), nis.size());
  check_step(name_, plots.size(), status.size());
  step_lanes(plots, status, nis.data());
}

void LaneStorage::candidate_log_likelihoods(
    std::span<const Eigen::Vector2d> plots, double gate,
    Eigen::Ref<Eigen::MatrixXd> out) {  // NOLINT(performance-unnecessary-value-param)
  check_candidates(name_, plots.size(), gate, out.rows(), out.cols());
  score_lanes(plots, gate, nullptr, out);
}

void LaneStorage::candidate_log_likelihoods(
    std::span<const Eigen::Vector2d> plots, double gate, std::span<const double> gate_scale,
    Eigen::Ref<Eigen::MatrixXd> out) {  // NOLINT(performance-unnecessary-value-param)
  check_candidates(name_, plots.size(), gate, out.rows(), out.cols());
  bank::check_gate_scale(gate_scale, out.rows());
  score_lanes(plots, gate, gate_scale.data(), out);
}

}  // namespace imm
