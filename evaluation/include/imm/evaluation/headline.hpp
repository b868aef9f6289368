// SPDX-License-Identifier: Apache-2.0
#pragma once
/// An experiment's headline metrics, kept with their per-run terms so that two evaluations on the
/// same test tracks (the same regime, seed and runs: the same noise) compare with the paired
/// bootstrap — the nightly's regression gate of a candidate model against the shipped one
/// (`imm-eval regression`). Every headline metric is an error: lower is better.
///
/// Each experiment writes `headline.json` beside its metrics.json:
///   {"experiment", "model", "model_sha256", "regime", "regime_digest", "seed", "runs",
///    "metrics": [{"name", "form", "value", "interval", "numerator", "denominator", ["counted"]}]}
/// with the per-run terms as arrays (runs) or arrays of arrays (runs × scans, for ζ).

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "imm/evaluation/uncertainty.hpp"

namespace imm::evaluation {

struct HeadlineMetric {
  enum class Form {
    kRatio,      ///< Σ w·numerator / Σ w·denominator (a mean square, a mean)
    kRootRatio,  ///< its square root (an RMSE)
    kScanZeta,  ///< seed 000's ζ: mean over scans of √(Σ w·e² / Σ w·m²), runs × scans terms
  };
  std::string name;
  Form form = Form::kRatio;
  Eigen::MatrixXd numerator, denominator;  ///< runs × 1, or runs × scans (ζ)
  Eigen::MatrixXd counted;                 ///< ζ: runs × scans, 1 where the scan has a sample

  [[nodiscard]] Eigen::Index runs() const { return numerator.rows(); }
  [[nodiscard]] double value() const;  ///< the statistic on the runs themselves
  [[nodiscard]] Statistic statistic() const;
};

/// A mean over runs of per-run values.
[[nodiscard]] HeadlineMetric mean_metric(std::string name, const Eigen::VectorXd& per_run);
/// √(Σ sums / Σ counts) over runs (an RMSE from per-run sums of squares and sample counts).
[[nodiscard]] HeadlineMetric rms_metric(std::string name, const Eigen::VectorXd& sums,
                                        const Eigen::VectorXd& counts);
/// Σ sums / Σ counts over runs (a mean square).
[[nodiscard]] HeadlineMetric ratio_metric(std::string name, const Eigen::VectorXd& sums,
                                          const Eigen::VectorXd& counts);

/// A (ratio or RMS) metric of one case's runs placed among all `runs` runs at `offset` (cases in
/// order): the other cases' runs weigh nothing in it, so per-case figures pair run by run too.
[[nodiscard]] HeadlineMetric in_case(HeadlineMetric metric, Eigen::Index offset, Eigen::Index runs);

/// What the evaluated runs were: two headline files compare only when these agree.
struct HeadlineRuns {
  std::string experiment;
  std::filesystem::path model;
  std::string regime, regime_digest;
  std::uint64_t seed = 0;
  int runs = 0;
};

/// Writes `out`/headline.json atomically (the model's SHA-256 is computed here).
void write_headline(const std::filesystem::path& out, const HeadlineRuns& runs,
                    const std::vector<HeadlineMetric>& metrics);

/// A headline file read back. Throws std::runtime_error naming the file and the field.
struct HeadlineFile {
  HeadlineRuns runs;
  std::string model_sha256;
  std::vector<HeadlineMetric> metrics;
};
[[nodiscard]] HeadlineFile read_headline(const std::filesystem::path& path);

/// A practical margin: a difference smaller than max(relative × |value|, absolute) is no news
/// for a tracking application, whatever its interval. `metric` names the metrics it applies to
/// (those whose name contains it; empty: every metric); per field, the rule with the longest
/// matching `metric` that sets it wins.
struct MarginRule {
  std::string metric;
  std::optional<double> relative, absolute;
};
/// Parses "[METRIC=]VALUE" (the form of `--relative-margin` / `--absolute-margin`) into a rule with
/// the value in the named field. Throws std::runtime_error on a bad or negative value.
[[nodiscard]] MarginRule parse_margin(const std::string& text, bool relative);

/// One metric of a candidate against the shipped model on the same runs.
///
/// Worse means worse beyond the Monte Carlo uncertainty *and* beyond the practical margin:
/// - the interval must lie beyond rounding: two models that differ only in the last bits of their
///   parameters give per-run differences of ~1e-15 relative whose bootstrap interval is as narrow
///   as they are — evidence of rounding, not of a regression. A difference whose interval lies
///   within kRoundingTolerance × |shipped| of zero is therefore a tie;
/// - the difference itself must exceed `margin` (from the MarginRule of the metric): a retraining
///   on another machine moves a trained model by its libm's rounding amplified through the
///   optimizer's path, which a paired comparison on 100 tracks can resolve but no application
///   can notice.
/// Better is the same on the other side.
struct Regression {
  static constexpr double kRoundingTolerance = 1e-9;
  std::string metric;
  double candidate = 0.0, shipped = 0.0;
  Difference difference;  ///< candidate − shipped with its 95 % paired-bootstrap interval
  double margin = 0.0;    ///< the practical margin, in the metric's unit
  [[nodiscard]] double rounding() const {
    return kRoundingTolerance * std::max(std::abs(shipped), std::abs(candidate));
  }
  [[nodiscard]] bool worse() const {
    return difference.lower > rounding() && difference.estimate > margin;
  }
  [[nodiscard]] bool better() const {
    return difference.upper < -rounding() && difference.estimate < -margin;
  }
};

/// Compares every headline metric of `candidate` with the same-named one of `shipped`, each with
/// its practical margin from `margins`. Throws std::runtime_error when they were not evaluated on
/// the same runs (experiment, regime digest, seed, number of runs) or a metric is missing.
[[nodiscard]] std::vector<Regression> compare_headlines(
    const HeadlineFile& candidate, const HeadlineFile& shipped,
    const std::vector<MarginRule>& margins = {});

}  // namespace imm::evaluation
