// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Linear assignment for multi-target tracking: which track takes which plot (global nearest
/// neighbour), and which estimate stands for which true target (GOSPA).
///
/// The solver is the shortest-augmenting-path method for rectangular problems (Jonker and
/// Volgenant's; the form of D. F. Crouse, "On implementing 2D rectangular assignment algorithms",
/// IEEE Trans. Aerospace and Electronic Systems 52(4), 2016, which SciPy's linear_sum_assignment
/// also follows): O(n² m) for an n × m matrix, n ≤ m, exact. It is written here, 60 lines with
/// their tests, because Debian packages no C++ assignment library for this (Eigen and Ceres have
/// none; OR-Tools and dlib are not packaged for this use).

#include <Eigen/Core>
#include <vector>

namespace imm::evaluation {

/// The assignment of the rows of `cost` to its columns that pairs min(rows, cols) of them, each
/// row and column at most once, with the least total cost; +∞ marks a pair that may not be made.
/// Returns for each row its column, or −1 for a row left out (only when rows > cols). Throws
/// InvalidParameter("cost") for a NaN or −∞ entry, or when no such assignment avoids every +∞.
[[nodiscard]] std::vector<int> min_cost_assignment(const Eigen::MatrixXd& cost);

/// Global nearest neighbour: rows (tracks) to columns (plots) where leaving a row or a column out
/// costs `unassigned` each, and a pair costs its entry (+∞: outside the gate, never made). A pair
/// is made only where that lowers the total: a pair costing more than 2 × `unassigned` (leaving
/// both out) never is. Returns for each row its column or −1.
/// Throws InvalidParameter("unassigned") unless it is finite and ≥ 0, and as min_cost_assignment.
[[nodiscard]] std::vector<int> gated_assignment(const Eigen::MatrixXd& cost, double unassigned);

}  // namespace imm::evaluation
