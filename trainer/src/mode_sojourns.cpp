// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/mode_sojourns.hpp"

#include <cmath>
#include <limits>
#include <string>
#include <unsupported/Eigen/MatrixFunctions>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/estimation/mode_transitions.hpp"

namespace imm::trainer {

SojournEstimate estimate_sojourns(std::span<const std::vector<int>> labels, int modes,
                                  double sample_period) {
  require(modes >= 1 && modes <= 16, "modes", "must be in [1, 16]");
  limits::require_in(sample_period, limits::kSamplePeriod, "sample_period");
  Eigen::MatrixXd counts = Eigen::MatrixXd::Zero(modes, modes);
  for (std::size_t t = 0; t < labels.size(); ++t) {
    const auto& sequence = labels[t];
    for (std::size_t k = 0; k < sequence.size(); ++k) {
      require(sequence[k] >= 0 && sequence[k] < modes,
              "labels[" + std::to_string(t) + "][" + std::to_string(k) + "]", "mode out of range");
      if (k > 0) counts(sequence[k - 1], sequence[k]) += 1.0;
    }
  }
  SojournEstimate estimate;
  estimate.time = counts.rowwise().sum() * sample_period;
  estimate.exits = Eigen::VectorXi::Zero(modes);
  Eigen::MatrixXd transition(modes, modes);
  for (int i = 0; i < modes; ++i) {
    const double steps = counts.row(i).sum();
    require(steps > 0.0, "labels", "mode " + std::to_string(i) + " is never observed");
    estimate.exits(i) = static_cast<int>(steps - counts(i, i));
    transition.row(i) = counts.row(i) / steps;
  }
  Eigen::MatrixXd q = transition.log() / sample_period;
  // Sampling noise can make a small rate come out negative (or a row of an unvisited pair a
  // rounding error away from zero): clamp and rebalance the diagonal.
  for (int i = 0; i < modes; ++i) {
    double out = 0.0;
    for (int j = 0; j < modes; ++j) {
      if (i == j) continue;
      q(i, j) = std::max(0.0, q(i, j));
      out += q(i, j);
    }
    q(i, i) = -out;
  }
  validate_generator(q);
  estimate.generator = q;
  estimate.mean_sojourn.resize(modes);
  estimate.standard_error.resize(modes);
  for (int i = 0; i < modes; ++i) {
    const double tau = q(i, i) < 0.0 ? -1.0 / q(i, i) : std::numeric_limits<double>::infinity();
    estimate.mean_sojourn(i) = tau;
    estimate.standard_error(i) =
        estimate.exits(i) > 0 ? tau / std::sqrt(static_cast<double>(estimate.exits(i))) : tau;
  }
  return estimate;
}

SojournEstimate estimate_maneuver_sojourns(const datasets::TrackSet& tracks) {
  std::vector<std::vector<int>> labels;
  labels.reserve(tracks.tracks.size());
  for (const auto& track : tracks.tracks) {
    std::vector<int> sequence(track.maneuvering.size());
    for (std::size_t k = 0; k < sequence.size(); ++k) sequence[k] = track.maneuvering[k] ? 1 : 0;
    labels.push_back(std::move(sequence));
  }
  return estimate_sojourns(labels, 2, tracks.sample_period);
}

}  // namespace imm::trainer
