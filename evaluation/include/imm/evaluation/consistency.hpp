// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Whether a filter is honest about its own errors: the normalized estimation error squared,
/// NEES = (x − x̂)ᵀ P⁻¹ (x − x̂), and the normalized innovation squared, NIS = νᵀ S⁻¹ ν, averaged
/// over N independent runs. For a consistent filter N·(average NEES) is χ² with N·n degrees of
/// freedom (n the dimension), so the average lies in [χ²_{Nn}(α/2), χ²_{Nn}(1 − α/2)] / N with
/// probability 1 − α (Bar-Shalom, Li & Kirubarajan, Estimation with Applications to Tracking and
/// Navigation, §5.4.2). An average above the bounds: the filter is optimistic (its covariance is
/// too small); below: pessimistic.

#include <Eigen/Core>
#include <span>
#include <string>

#include "imm/evaluation/headline.hpp"
#include "imm/math/chi_square.hpp"

namespace imm::evaluation {

/// (imm/math/chi_square.hpp: the runtime's envelope monitor uses them too.)
using imm::chi_square_quantile;
using imm::regularized_gamma_p;

/// The two-sided bounds of an average of `runs` independent NEES or NIS values of dimension
/// `dimension` under consistency, at `confidence` (0.95: the 2.5 and 97.5 % quantiles).
struct ConsistencyBounds {
  double lower = 0.0;
  double upper = 0.0;
  /// Where `average` lies: "consistent", "optimistic" (above: the covariance is too small) or
  /// "pessimistic" (below).
  [[nodiscard]] const char* verdict(double average) const;
};
[[nodiscard]] ConsistencyBounds average_bounds(int dimension, long runs, double confidence = 0.95);

/// A consistency statistic (position NEES or NIS) over a Monte Carlo evaluation: the average over
/// runs at every scan, checked against that scan's bounds (for the runs that have a value there).
struct ConsistencySummary {
  int dimension = 2;         ///< of the statistic (its average is `dimension` when consistent)
  double average = 0.0;      ///< mean over scans of the per-scan averages
  double inside = 0.0;       ///< share of scans whose average lies within its 95 % bounds
  double above = 0.0;        ///< share above them: the filter claims more accuracy than it has
  ConsistencyBounds bounds;  ///< the bounds of a scan with every run
  long scans = 0;            ///< scans with at least one run
  /// "consistent" (≥ 90 % of the scans inside), "optimistic" or "pessimistic" (more scans outside
  /// on that side); "–" without scans.
  [[nodiscard]] const char* verdict() const;
};

/// From runs × scans values of a statistic of `dimension` (NaN where a run has none).
[[nodiscard]] ConsistencySummary summarize_consistency(const Eigen::MatrixXd& run_values,
                                                       int dimension);

/// A filter's position NEES and NIS, for the consistency table.
struct FilterConsistency {
  std::string name;
  ConsistencySummary position_nees;
  ConsistencySummary nis;
};

/// Every filter's position NEES and NIS against their χ² bounds, as a Markdown table with the rule
/// in words: "filter | position NEES | scans inside | NIS | scans inside | verdict".
[[nodiscard]] std::string consistency_table(std::span<const FilterConsistency> filters);

/// Per run: |ln(ANEES / dimension)|, the run's NEES averaged over its scans with an estimate,
/// against the value a consistent filter averages to (0 when consistent; ln 3 ≈ 1.1 when the
/// covariance is a third of the errors', or three times them). NaN-only runs give 0. An error
/// measure of consistency, so that the regression gate can hold back a candidate whose covariance
/// got less honest beyond the Monte Carlo uncertainty.
[[nodiscard]] Eigen::VectorXd nees_log_ratio(const Eigen::MatrixXd& run_nees, int dimension);

/// The regression gate's consistency metric: the mean over runs of nees_log_ratio (lower is
/// better), as the headline metric `name` (by convention "position_nees_log_ratio", with the
/// experiment's case or filter in the name where it has several).
[[nodiscard]] HeadlineMetric nees_log_ratio_metric(std::string name,
                                                   const Eigen::MatrixXd& run_nees, int dimension);

}  // namespace imm::evaluation
