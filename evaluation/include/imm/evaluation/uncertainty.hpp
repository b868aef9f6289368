// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The Monte Carlo uncertainty of a comparison: a paired bootstrap over the runs (tracks). Both
/// filters ran on the same tracks, so the tracks are resampled together and the difference of the
/// two statistics is recomputed on each resample; its 2.5 and 97.5 percentiles bound it. "A beats
/// B" means the whole interval of a − b lies on the better side of zero.
///
/// A statistic is a function of per-run weights w (how often each run is drawn; all ones for the
/// estimate itself), so that ratios of sums (seed 000's ζ) are resampled as what they are.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>

namespace imm::evaluation {

using Statistic = std::function<double(const Eigen::VectorXd& weights)>;

struct Difference {
  double estimate = 0.0;            ///< a − b on the runs themselves
  double lower = 0.0, upper = 0.0;  ///< 95 % paired-bootstrap interval
  /// a is lower (better, for an error) than b beyond the uncertainty.
  [[nodiscard]] bool below() const { return upper < 0.0; }
  [[nodiscard]] bool above() const { return lower > 0.0; }
  /// "−0.0123 [−0.0150, −0.0097]" with `decimals` decimals; a difference whose every number
  /// rounds to zero there (but is not zero) to three significant digits: "+3.2e-06 [+1.1e-06, …]".
  [[nodiscard]] std::string text(int decimals = 4) const;
};

/// Differences within this fraction of the statistics themselves are rounding, not a difference.
inline constexpr double kRoundingLevel = 1e-9;

/// Paired bootstrap of a − b over `runs` runs (draws resamples, seeded: deterministic). When the
/// estimate and both bounds lie within kRoundingLevel × max(|a|, |b|) of zero, the difference is
/// exactly zero (the same filter computed two ways ties itself).
[[nodiscard]] Difference paired_difference(int runs, const Statistic& a, const Statistic& b,
                                           std::uint64_t seed = 7, int draws = 1000);

/// The weighted mean of per-run values (the statistic of a per-run mean metric).
[[nodiscard]] Statistic mean_of(const Eigen::VectorXd& per_run);

/// The sign convention of every comparison, in words, for the reports.
inline constexpr std::string_view kDifferenceConvention =
    "A difference is the named filter's error minus the other's, with its 95 % paired-bootstrap "
    "interval over the runs: below zero the named filter is better (every metric here is an "
    "error: lower is better).";

/// How the named filter compares with another over several error metrics, each given as
/// named − other with its interval: "beats" when it is better beyond the interval in at least one
/// metric and worse in none, "loses to" when worse in at least one and better in none, "mixed"
/// when better in one and worse in another, "ties" when no metric differs beyond its interval.
[[nodiscard]] std::string_view verdict(std::span<const Difference> differences);

/// The rule of verdict(), in words, for the reports.
inline constexpr std::string_view kVerdictRule =
    "Verdicts: \"beats\" = better beyond the interval in at least one metric and worse in none; "
    "\"loses to\" = worse in at least one and better in none; \"mixed\" = better in one and "
    "worse in another; \"ties\" = no metric differs beyond its interval.";

/// The standard error of the mean of per-run values.
[[nodiscard]] double standard_error(const Eigen::VectorXd& per_run);

}  // namespace imm::evaluation
