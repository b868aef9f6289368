// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/consistency.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "imm/evaluation/report.hpp"

namespace imm::evaluation {

const char* ConsistencyBounds::verdict(double average) const {
  if (average > upper) return "optimistic";
  if (average < lower) return "pessimistic";
  return "consistent";
}

ConsistencyBounds average_bounds(int dimension, long runs, double confidence) {
  if (dimension < 1 || runs < 1 || !(confidence > 0.0 && confidence < 1.0)) {
    throw std::invalid_argument(
        "average_bounds: needs dimension ≥ 1, runs ≥ 1, 0 < confidence < 1");
  }
  const double dof = static_cast<double>(dimension) * static_cast<double>(runs);
  const double tail = (1.0 - confidence) / 2.0;
  return {chi_square_quantile(tail, dof) / static_cast<double>(runs),
          chi_square_quantile(1.0 - tail, dof) / static_cast<double>(runs)};
}

const char* ConsistencySummary::verdict() const {
  if (scans == 0) return "–";
  if (inside >= 0.9) return "consistent";
  return above >= 1.0 - inside - above ? "optimistic" : "pessimistic";
}

namespace {

// The sum and the count of the finite values of a row or column (NaN: no estimate there).
struct FiniteSum {
  double sum = 0.0;
  long count = 0;
};
template <class Values>
FiniteSum finite_sum(const Values& values) {
  FiniteSum s;
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    if (std::isfinite(values(i))) {
      s.sum += values(i);
      ++s.count;
    }
  }
  return s;
}

}  // namespace

ConsistencySummary summarize_consistency(const Eigen::MatrixXd& run_values, int dimension) {
  ConsistencySummary summary;
  summary.dimension = dimension;
  const auto runs = static_cast<long>(run_values.rows());
  if (runs == 0) return summary;
  summary.bounds = average_bounds(dimension, runs);
  double sum = 0.0;
  long inside = 0, above = 0;
  for (Eigen::Index k = 0; k < run_values.cols(); ++k) {
    const auto [scan_sum, count] = finite_sum(run_values.col(k));
    if (count == 0) continue;
    const double average = scan_sum / static_cast<double>(count);
    const ConsistencyBounds bounds =
        count == runs ? summary.bounds : average_bounds(dimension, count);
    inside += average >= bounds.lower && average <= bounds.upper ? 1 : 0;
    above += average > bounds.upper ? 1 : 0;
    sum += average;
    ++summary.scans;
  }
  if (summary.scans > 0) {
    const auto scans = static_cast<double>(summary.scans);
    summary.average = sum / scans;
    summary.inside = static_cast<double>(inside) / scans;
    summary.above = static_cast<double>(above) / scans;
  }
  return summary;
}

std::string consistency_table(std::span<const FilterConsistency> filters) {
  std::vector<std::vector<std::string>> rows;
  auto bounds = [](const ConsistencySummary& c) {
    return "[" + cell(c.bounds.lower, 2) + ", " + cell(c.bounds.upper, 2) + "]";
  };
  for (const FilterConsistency& f : filters) {
    const ConsistencySummary &nees = f.position_nees, &nis = f.nis;
    // No NEES without truth (recorded plots): its cells are dashes.
    rows.push_back({f.name, nees.scans > 0 ? cell(nees.average, 2) : "–",
                    nees.scans > 0 ? bounds(nees) : "–",
                    nees.scans > 0 ? cell(100.0 * nees.inside, 1) + " %" : "–",
                    nis.scans > 0 ? cell(nis.average, 2) : "–", nis.scans > 0 ? bounds(nis) : "–",
                    nis.scans > 0 ? cell(100.0 * nis.inside, 1) + " %" : "–",
                    std::string(nees.verdict()) + " / " + nis.verdict()});
  }
  return markdown_table({"filter", "position NEES", "95 % bounds", "scans inside", "NIS",
                         "95 % bounds", "scans inside", "consistency (NEES / NIS)"},
                        rows) +
         "\nPosition NEES (x − x̂)ᵀ P⁻¹ (x − x̂) over the position block, and NIS νᵀ S⁻¹ ν of "
         "the plot's innovation, each averaged over the runs at every scan and then over the "
         "scans: equal to their dimension (2, or 1 per axis) when the filter's covariance matches "
         "its "
         "errors. A scan's average lies within "
         "the two-sided 95 % χ² bounds for the number of runs (the bounds shown: a scan with "
         "every run) 95 % of the time for a consistent filter. \"optimistic\": more scans above "
         "the bounds (the filter claims more accuracy than it has) than below; \"consistent\": at "
         "least 90 % of the scans inside.\n";
}

HeadlineMetric nees_log_ratio_metric(std::string name, const Eigen::MatrixXd& run_nees,
                                     int dimension) {
  return mean_metric(std::move(name), nees_log_ratio(run_nees, dimension));
}

Eigen::VectorXd nees_log_ratio(const Eigen::MatrixXd& run_nees, int dimension) {
  Eigen::VectorXd per_run = Eigen::VectorXd::Zero(run_nees.rows());
  for (Eigen::Index r = 0; r < run_nees.rows(); ++r) {
    const auto [sum, count] = finite_sum(run_nees.row(r));
    if (count > 0 && sum > 0.0) {
      per_run(r) = std::abs(std::log(sum / static_cast<double>(count) / dimension));
    }
  }
  return per_run;
}

}  // namespace imm::evaluation
