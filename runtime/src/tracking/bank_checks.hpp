// SPDX-License-Identifier: Apache-2.0
#pragma once
// The argument checks every multi-track bank makes, with one wording. Not installed.

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "imm/core/invalid_parameter.hpp"

namespace imm::bank {

/// The most tracks a bank holds.
inline constexpr std::size_t kMaxCapacity = std::size_t{1} << 26U;

/// InvalidParameter("capacity") unless 1 ≤ capacity ≤ kMaxCapacity.
inline void require_capacity(std::size_t capacity) {
  if (capacity < 1 || capacity > kMaxCapacity) {
    throw InvalidParameter("capacity", "must be in [1, " + std::to_string(kMaxCapacity) +
                                           "] tracks, got " + std::to_string(capacity));
  }
}

/// InvalidParameter("transition") unless every entry of Π is positive: c_j then never vanishes,
/// so no mode is ever unreachable and the banks need no fallback.
inline void require_positive_transitions(const Eigen::MatrixXd& transition) {
  if (!(transition.array() > 0.0).all()) {
    throw InvalidParameter("transition", "the bank needs every transition probability > 0");
  }
}

/// `track`, or std::out_of_range when it is not below `capacity`.
inline std::size_t checked_track(std::size_t track, std::size_t capacity) {
  if (track >= capacity) {
    throw std::out_of_range("track " + std::to_string(track) + " outside a bank of " +
                            std::to_string(capacity));
  }
  return track;
}

/// Before `bank`'s step of plots.size() tracks: std::invalid_argument when the spans differ or
/// exceed the capacity, std::logic_error naming the first stepped track never initialized.
inline void check_step(std::string_view bank, std::size_t plots, std::size_t statuses,
                       const std::vector<unsigned char>& initialized) {
  if (plots != statuses || plots > initialized.size()) {
    throw std::invalid_argument(std::string(bank) + "::step: " + std::to_string(plots) +
                                " plots and " + std::to_string(statuses) +
                                " statuses for a bank of " + std::to_string(initialized.size()));
  }
  for (std::size_t t = 0; t < plots; ++t) {
    if (initialized[t] == 0) {
      throw std::logic_error(std::string(bank) + "::step: track " + std::to_string(t) +
                             " was never initialized");
    }
  }
}

/// Before `bank`'s candidate_log_likelihoods of `plots` plots into a rows × cols matrix:
/// std::invalid_argument when cols differs from plots or rows exceeds the capacity,
/// InvalidParameter("gate") for a gate that is NaN or not positive, std::logic_error naming the
/// first track never initialized.
inline void check_candidates(std::string_view bank, std::size_t plots, double gate,
                             Eigen::Index rows, Eigen::Index cols,
                             const std::vector<unsigned char>& initialized) {
  const auto tracks = static_cast<std::size_t>(rows);
  if (static_cast<std::size_t>(cols) != plots || tracks > initialized.size()) {
    throw std::invalid_argument(std::string(bank) + "::candidate_log_likelihoods: a " +
                                std::to_string(rows) + " × " + std::to_string(cols) +
                                " matrix for " + std::to_string(plots) + " plots and a bank of " +
                                std::to_string(initialized.size()));
  }
  if (!(gate > 0.0)) throw InvalidParameter("gate", "must be positive (+∞ scores every pair)");
  check_step(bank, tracks, tracks, initialized);
}

/// Per-track gate factors of a gating matrix of `rows` tracks: one per row, each finite and
/// positive; InvalidParameter("gate_scale") or ("gate_scale[t]") otherwise.
inline void check_gate_scale(std::span<const double> gate_scale, Eigen::Index rows) {
  if (gate_scale.size() != static_cast<std::size_t>(rows)) {
    throw InvalidParameter("gate_scale", "needs one factor per track (" + std::to_string(rows) +
                                             "), has " + std::to_string(gate_scale.size()));
  }
  for (std::size_t t = 0; t < gate_scale.size(); ++t) {
    if (!(std::isfinite(gate_scale[t]) && gate_scale[t] > 0.0)) {
      throw InvalidParameter("gate_scale[" + std::to_string(t) + "]", "must be finite and > 0");
    }
  }
}

/// A step's NIS output for `plots` tracks: as many entries; std::invalid_argument otherwise.
inline void check_nis(std::string_view bank, std::size_t plots, std::size_t nis) {
  if (nis != plots) {
    throw std::invalid_argument(std::string(bank) + "::step: " + std::to_string(nis) +
                                " NIS entries for " + std::to_string(plots) + " plots");
  }
}

}  // namespace imm::bank
