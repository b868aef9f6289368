// SPDX-License-Identifier: Apache-2.0
#include "imm/tracking/track_bank_calls.hpp"

#include "bank_checks.hpp"

namespace imm {

void TrackBankCalls::hold_tracks(std::size_t capacity) {
  bank::require_capacity(capacity);
  initialized_.assign(capacity, 0);
}

bool TrackBankCalls::initialized(std::size_t track) const {
  return initialized_[static_cast<std::size_t>(checked(track))] != 0;
}

std::ptrdiff_t TrackBankCalls::checked(std::size_t track) const {
  return static_cast<std::ptrdiff_t>(bank::checked_track(track, capacity()));
}

void TrackBankCalls::step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status) {
  bank::check_step(name_, plots.size(), status.size(), initialized_);
  step_lanes({plots, status, nullptr});
}

void TrackBankCalls::step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status,
                          std::span<double> nis) {
  bank::check_nis(name_, plots.size(), nis.size());
  bank::check_step(name_, plots.size(), status.size(), initialized_);
  step_lanes({plots, status, nis.data()});
}

void TrackBankCalls::candidate_log_likelihoods(
    std::span<const Eigen::Vector2d> plots, double gate,
    Eigen::Ref<Eigen::MatrixXd> out) {  // NOLINT(performance-unnecessary-value-param): a view
  bank::check_candidates(name_, plots.size(), gate, out.rows(), out.cols(), initialized_);
  score_lanes({plots, gate, nullptr, out});
}

void TrackBankCalls::candidate_log_likelihoods(
    std::span<const Eigen::Vector2d> plots, double gate, std::span<const double> gate_scale,
    Eigen::Ref<Eigen::MatrixXd> out) {  // NOLINT(performance-unnecessary-value-param): a view
  bank::check_candidates(name_, plots.size(), gate, out.rows(), out.cols(), initialized_);
  bank::check_gate_scale(gate_scale, out.rows());
  score_lanes({plots, gate, gate_scale.data(), out});
}

}  // namespace imm
