// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/assignment.hpp"

#include <cmath>
#include <limits>
#include <string>

#include "imm/core/invalid_parameter.hpp"

namespace imm::evaluation {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Rows ≤ columns. Dual potentials u (rows) and v (columns); for each row in turn a Dijkstra-like
// search over the reduced costs c_ij − u_i − v_j finds the shortest augmenting path to a free
// column, the potentials are updated and the path augmented (Crouse 2016, Algorithm 1).
std::vector<int> solve_wide(const Eigen::MatrixXd& c) {
  const auto n = static_cast<int>(c.rows());
  const auto m = static_cast<int>(c.cols());
  std::vector<double> u(static_cast<std::size_t>(n), 0.0), v(static_cast<std::size_t>(m), 0.0);
  std::vector<double> shortest(static_cast<std::size_t>(m));
  std::vector<int> path(static_cast<std::size_t>(m)), column_of(static_cast<std::size_t>(n), -1),
      row_of(static_cast<std::size_t>(m), -1);
  std::vector<char> seen_row(static_cast<std::size_t>(n)), seen_column(static_cast<std::size_t>(m));
  std::vector<int> remaining(static_cast<std::size_t>(m));
  for (int start = 0; start < n; ++start) {
    std::fill(shortest.begin(), shortest.end(), kInf);
    std::fill(path.begin(), path.end(), -1);
    std::fill(seen_row.begin(), seen_row.end(), 0);
    std::fill(seen_column.begin(), seen_column.end(), 0);
    int left = m;
    for (int j = 0; j < m; ++j) remaining[static_cast<std::size_t>(j)] = m - j - 1;
    double minimum = 0.0;
    int i = start, sink = -1;
    while (sink == -1) {
      seen_row[static_cast<std::size_t>(i)] = 1;
      int index = -1;
      double lowest = kInf;
      for (int it = 0; it < left; ++it) {
        const int j = remaining[static_cast<std::size_t>(it)];
        const double reduced =
            minimum + c(i, j) - u[static_cast<std::size_t>(i)] - v[static_cast<std::size_t>(j)];
        if (reduced < shortest[static_cast<std::size_t>(j)]) {
          path[static_cast<std::size_t>(j)] = i;
          shortest[static_cast<std::size_t>(j)] = reduced;
        }
        // Ties prefer a free column: the path ends sooner.
        if (shortest[static_cast<std::size_t>(j)] < lowest ||
            (shortest[static_cast<std::size_t>(j)] == lowest &&
             row_of[static_cast<std::size_t>(j)] == -1)) {
          lowest = shortest[static_cast<std::size_t>(j)];
          index = it;
        }
      }
      minimum = lowest;
      if (!(minimum < kInf)) {
        throw InvalidParameter("cost",
                               "no assignment of every row avoids the forbidden (+∞) pairs");
      }
      const int j = remaining[static_cast<std::size_t>(index)];
      if (row_of[static_cast<std::size_t>(j)] == -1)
        sink = j;
      else
        i = row_of[static_cast<std::size_t>(j)];
      seen_column[static_cast<std::size_t>(j)] = 1;
      remaining[static_cast<std::size_t>(index)] = remaining[static_cast<std::size_t>(--left)];
    }
    u[static_cast<std::size_t>(start)] += minimum;
    for (int r = 0; r < n; ++r) {
      if (seen_row[static_cast<std::size_t>(r)] && r != start) {
        u[static_cast<std::size_t>(r)] +=
            minimum - shortest[static_cast<std::size_t>(column_of[static_cast<std::size_t>(r)])];
      }
    }
    for (int j = 0; j < m; ++j) {
      if (seen_column[static_cast<std::size_t>(j)]) {
        v[static_cast<std::size_t>(j)] -= minimum - shortest[static_cast<std::size_t>(j)];
      }
    }
    for (int j = sink;;) {  // augment along the path back to `start`
      const int r = path[static_cast<std::size_t>(j)];
      row_of[static_cast<std::size_t>(j)] = r;
      const int previous = column_of[static_cast<std::size_t>(r)];
      column_of[static_cast<std::size_t>(r)] = j;
      if (r == start) break;
      j = previous;
    }
  }
  return column_of;
}

}  // namespace

std::vector<int> min_cost_assignment(const Eigen::MatrixXd& cost) {
  for (Eigen::Index i = 0; i < cost.size(); ++i) {
    const double value = cost.data()[i];
    if (std::isnan(value) || value == -kInf) {
      throw InvalidParameter("cost", "an entry is NaN or −∞ (only +∞ marks a forbidden pair)");
    }
  }
  if (cost.rows() <= cost.cols()) return solve_wide(cost);
  const std::vector<int> row_of = solve_wide(cost.transpose());
  std::vector<int> column_of(static_cast<std::size_t>(cost.rows()), -1);
  for (std::size_t j = 0; j < row_of.size(); ++j) {
    column_of[static_cast<std::size_t>(row_of[j])] = static_cast<int>(j);
  }
  return column_of;
}

std::vector<int> gated_assignment(const Eigen::MatrixXd& cost, double unassigned) {
  if (!std::isfinite(unassigned) || unassigned < 0.0) {
    throw InvalidParameter("unassigned", "must be finite and ≥ 0");
  }
  // [[C, D], [D', 0]]: row i may instead take its own dummy column (cost `unassigned`), column j
  // its own dummy row; dummy with dummy costs nothing. Every row and column is then assignable.
  const Eigen::Index n = cost.rows(), m = cost.cols();
  Eigen::MatrixXd augmented = Eigen::MatrixXd::Constant(n + m, m + n, kInf);
  augmented.topLeftCorner(n, m) = cost;
  for (Eigen::Index i = 0; i < n; ++i) augmented(i, m + i) = unassigned;
  for (Eigen::Index j = 0; j < m; ++j) augmented(n + j, j) = unassigned;
  augmented.bottomRightCorner(m, n).setZero();
  const std::vector<int> chosen = min_cost_assignment(augmented);
  std::vector<int> out(static_cast<std::size_t>(n), -1);
  for (Eigen::Index i = 0; i < n; ++i) {
    const int j = chosen[static_cast<std::size_t>(i)];
    if (j < m) out[static_cast<std::size_t>(i)] = j;
  }
  return out;
}

}  // namespace imm::evaluation
