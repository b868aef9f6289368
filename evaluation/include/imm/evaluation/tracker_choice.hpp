// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The regime's tracker: which filter a tracking application should load for a regime, chosen
/// among the learned models trained for it and the tuned classical baseline, on the same test
/// tracks (`imm-eval rank`).
///
/// The baseline is the classical bar: the best of the regime's tuned classical filters on the
/// same tracks (the others are ranked beside it, never chosen). The rule: a learned model is
/// eligible only when it *beats* the bar (verdict() over ζ_p
/// and ζ_v: better beyond the 95 % paired-bootstrap interval in at least one, worse in neither).
/// A learned model is also held out when its own experiment failed its gates, or when no
/// evaluation of that very file says it passed them (RankedFilter::held_out), and when its
/// covariance is less consistent than both a consistent filter and the bar
/// (consistency_hold()): a tracking application gates on it.
/// Among the eligible ones the lowest ζ_p + ζ_v wins (without truth: the two criteria are the
/// predictive NLL per plot and the innovation RMS, and the lowest NLL wins); when none is eligible
/// the baseline is shipped — a learned model that only ties it has not earned its extra parts.

#include <array>
#include <cstddef>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "imm/evaluation/uncertainty.hpp"

namespace imm::evaluation {

struct RankedFilter {
  std::string name;  ///< the model file's stem
  std::string kind;  ///< its model_kind
  /// The classical bar: the best of the regime's tuned classical filters (exactly one).
  bool baseline = false;
  /// Another tuned classical filter, ranked but never the tracker in the bar's place.
  bool classical = false;
  /// The two criteria of the verdict, lower is better: ζ_p and ζ_v, or — on recorded plots without
  /// truth — the predictive NLL per plot and the innovation RMS (`criteria` names them).
  double zeta_p = 0.0, zeta_v = 0.0;
  std::array<std::string, 2> criteria{"ζ_p", "ζ_v"};
  /// What orders the filters (lowest first): ζ_p + ζ_v by default, the predictive NLL without
  /// truth (NaN: the sum of the criteria).
  double score = std::numeric_limits<double>::quiet_NaN();
  double position_rmse = 0.0, velocity_rmse = 0.0;
  Difference versus_baseline_p, versus_baseline_v;  ///< this − baseline (zero for the baseline)
  /// Its position NEES on the same tracks (without truth: its NIS): the verdict against the
  /// per-scan 95 % bounds ("consistent", "optimistic", "pessimistic"), the average and the share
  /// of scans inside.
  std::string consistency = "consistent";
  double position_nees = 0.0, scans_inside = 1.0;
  /// The share of scans whose NIS lies inside its 95 % bounds (with truth scans_inside is the
  /// NEES's; without, the two are the same).
  double nis_inside = 1.0;
  /// The scans each share is over (0: not known, the shares taken as exact).
  long scans = 0, nis_scans = 0;
  /// Why a learned model may not be the tracker whatever its figures (its own experiment's gates
  /// failed, or no evaluation of it was given); empty: eligible.
  std::string held_out;
};

struct TrackerChoice {
  std::size_t winner = 0;          ///< index into the filters
  std::vector<std::size_t> order;  ///< every filter by ζ_p + ζ_v, lowest first
  std::string reason;              ///< why the winner won, in one sentence with its numbers
  /// Per filter, why it is held out of the choice ("own gates: …" from RankedFilter::held_out, or
  /// consistency_hold()'s "consistency: …"); empty where it is not (and for classical filters).
  std::vector<std::string> held;
};

/// Applies the rule above. Throws std::invalid_argument unless exactly one filter is the baseline.
[[nodiscard]] TrackerChoice choose_tracker(std::span<const RankedFilter> filters);

/// The verdict of a filter against the baseline ("beats", "ties", "loses to", "mixed"; "—" for the
/// baseline itself).
[[nodiscard]] std::string verdict_against_baseline(const RankedFilter& filter);

/// The share of scans inside the 95 % bounds a consistent filter reaches (ConsistencySummary).
inline constexpr double kConsistentShare = 0.9;

/// Why `filter`'s covariance holds it back from being the tracker, or empty: its position NEES
/// (with truth) or its NIS lies inside the per-scan 95 % bounds on fewer scans than both
/// kConsistentShare and `bar` does, beyond the Monte Carlo uncertainty of a share over its scans
/// (1.96 binomial standard errors of the required share: on 118 scans one scan is 0.8 % and
/// decides nothing). A learned model must be consistent, or at least as consistent as the
/// classical filter it would replace where that one is not.
[[nodiscard]] std::string consistency_hold(const RankedFilter& filter, const RankedFilter& bar);

/// A learned model that beats the baseline in accuracy but whose covariance does not match its
/// errors (its position NEES outside the 95 % bounds on more than a tenth of the scans) is flagged:
/// the finding's text, or empty when there is nothing to flag. It stays eligible as the tracker —
/// an application that gates or fuses on its covariance needs to know.
[[nodiscard]] std::string inconsistency_finding(const RankedFilter& filter);

}  // namespace imm::evaluation
