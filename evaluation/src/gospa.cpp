// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/gospa.hpp"

#include <algorithm>
#include <cmath>

#include "imm/core/invalid_parameter.hpp"
#include "imm/evaluation/assignment.hpp"

namespace imm::evaluation {

Gospa gospa(const Eigen::Matrix2Xd& targets, const Eigen::Matrix2Xd& estimates, double cutoff,
            double order) {
  if (!(cutoff > 0.0) || !std::isfinite(cutoff)) {
    throw InvalidParameter("cutoff", "must be positive and finite");
  }
  if (!(order >= 1.0) || !std::isfinite(order)) throw InvalidParameter("order", "must be ≥ 1");
  if (!targets.allFinite()) throw InvalidParameter("targets", "a position is not finite");
  if (!estimates.allFinite()) throw InvalidParameter("estimates", "a position is not finite");
  const Eigen::Index n = targets.cols(), m = estimates.cols();
  const double capped = std::pow(cutoff, order);  // a pair at c or beyond: a miss and a false one
  Gospa out;
  out.estimate_of.assign(static_cast<std::size_t>(n), -1);
  if (n > 0 && m > 0) {
    Eigen::MatrixXd cost(n, m);
    for (Eigen::Index i = 0; i < n; ++i) {
      for (Eigen::Index j = 0; j < m; ++j) {
        const double d = (targets.col(i) - estimates.col(j)).norm();
        cost(i, j) = d < cutoff ? std::pow(d, order) : capped;
      }
    }
    const std::vector<int> chosen = min_cost_assignment(cost);
    for (Eigen::Index i = 0; i < n; ++i) {
      const int j = chosen[static_cast<std::size_t>(i)];
      if (j < 0 || !(cost(i, j) < capped)) continue;
      out.estimate_of[static_cast<std::size_t>(i)] = j;
      out.localization += cost(i, j);
      ++out.assigned;
    }
  }
  out.missed_targets = static_cast<int>(n) - out.assigned;
  out.false_estimates = static_cast<int>(m) - out.assigned;
  out.missed = 0.5 * capped * out.missed_targets;
  out.false_tracks = 0.5 * capped * out.false_estimates;
  out.distance = std::pow(out.localization + out.missed + out.false_tracks, 1.0 / order);
  return out;
}

}  // namespace imm::evaluation
