// SPDX-License-Identifier: Apache-2.0
#include "imm/estimation/mode_transitions.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <unsupported/Eigen/MatrixFunctions>

#include "imm/core/checks.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"

namespace imm {

void validate_generator(const Eigen::MatrixXd& generator) {
  const Eigen::Index n = generator.rows();
  require(n >= 1 && generator.cols() == n, "generator", "must be square");
  require(generator.allFinite(), "generator", "has non-finite entries");
  for (Eigen::Index i = 0; i < n; ++i) {
    double scale = 0.0;
    for (Eigen::Index j = 0; j < n; ++j) {
      if (i != j) {
        require(generator(i, j) >= 0.0,
                "generator[" + std::to_string(i) + "][" + std::to_string(j) + "]",
                "a rate must be non-negative");
      }
      scale = std::max(scale, std::abs(generator(i, j)));
    }
    require(std::abs(generator.row(i).sum()) <= 1e-9 * std::max(scale, 1e-300), "generator",
            "row " + std::to_string(i) + " does not sum to zero");
  }
}

Eigen::MatrixXd transition_matrix(const Eigen::MatrixXd& generator, double sample_period) {
  validate_generator(generator);
  limits::require_sample_period(sample_period, "sample_period");
  Eigen::MatrixXd transition = (generator * sample_period).exp();
  // exp keeps the rows summing to one up to rounding; clamp rounding below zero and renormalize
  // so that the result passes the IMM's own check.
  transition = transition.cwiseMax(0.0);
  for (Eigen::Index i = 0; i < transition.rows(); ++i) {
    transition.row(i) /= transition.row(i).sum();
  }
  const auto n = static_cast<int>(transition.rows());
  validate_mode_probabilities(transition, Eigen::VectorXd::Constant(n, 1.0 / n), n);
  return transition;
}

Eigen::MatrixXd two_mode_generator(double first, double second) {
  limits::require_in(first, limits::kTimeConstant, "mean_sojourn[0]");
  limits::require_in(second, limits::kTimeConstant, "mean_sojourn[1]");
  Eigen::MatrixXd q(2, 2);
  q << -1.0 / first, 1.0 / first, 1.0 / second, -1.0 / second;
  return q;
}

void transition_over(const ModeMatrix& per_period, double periods, ModeMatrix& out) {
  const Eigen::Index n = per_period.rows();
  out.resize(n, n);
  if (periods == 1.0) {
    out = per_period;
    return;
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    const double stay = per_period(i, i);
    const double kept = std::pow(stay, periods);
    // The share of the per-period switching probability this interval switches (1 at Δt = T).
    const double share = stay < 1.0 ? (1.0 - kept) / (1.0 - stay) : 0.0;
    for (Eigen::Index j = 0; j < n; ++j) out(i, j) = i == j ? kept : per_period(i, j) * share;
  }
}

}  // namespace imm
