// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The generalized optimal sub-pattern assignment metric (GOSPA, α = 2) between the true targets
/// and a tracker's estimates at one scan: A. S. Rahmathullah, Á. F. García-Fernández and
/// L. Svensson, "Generalized optimal sub-pattern assignment metric", FUSION 2017. With cut-off c
/// and order p,
///
///   d(X, Y)^p = min over assignments γ [ Σ_{(i,j) ∈ γ} d(x_i, y_j)^p + c^p/2 (|X| + |Y| − 2|γ|) ]
///
/// over the pairs at distance below c, so that the metric splits into localization (the assigned
/// pairs' distances), missed targets and false tracks (c^p/2 each). Distances are Euclidean in the
/// position.

#include <Eigen/Core>
#include <vector>

namespace imm::evaluation {

/// One scan's GOSPA and its parts (each part in the metric's p-th power, so that they add up).
struct Gospa {
  double distance = 0.0;      ///< d(X, Y) = (localization + missed + false)^(1/p)
  double localization = 0.0;  ///< Σ d^p over the assigned pairs
  double missed = 0.0;        ///< c^p/2 × the targets without an estimate
  double false_tracks = 0.0;  ///< c^p/2 × the estimates without a target
  int assigned = 0;           ///< |γ|
  int missed_targets = 0;     ///< |X| − |γ|
  int false_estimates = 0;    ///< |Y| − |γ|
  /// For each target, the estimate assigned to it, or −1.
  std::vector<int> estimate_of;
};

/// GOSPA between targets (2 × n positions) and estimates (2 × m), cut-off c > 0, order p ≥ 1.
/// Throws InvalidParameter naming "cutoff", "order" or a non-finite position ("targets" /
/// "estimates").
[[nodiscard]] Gospa gospa(const Eigen::Matrix2Xd& targets, const Eigen::Matrix2Xd& estimates,
                          double cutoff, double order = 2.0);

}  // namespace imm::evaluation
