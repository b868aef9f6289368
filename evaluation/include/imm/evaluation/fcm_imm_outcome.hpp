// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The FCM-IMM experiment's Monte Carlo loop (seed 003's figures): a two-axis filter per test
/// track, started from its first two plots and scored from scan 2 on, with the position and
/// velocity RMSE over every scored scan and over the scans where a manoeuvre acts, and for an
/// FCM-IMM the manoeuvre fraction Σ_j μ_j (1 − u_noise,j). The runs are spread over the job's
/// ranks and summed in run order, as run_monte_carlo's.

#include <Eigen/Core>
#include <limits>
#include <string>

#include "imm/datasets/track.hpp"
#include "imm/evaluation/consistency.hpp"
#include "imm/evaluation/headline.hpp"
#include "imm/evaluation/uncertainty.hpp"
#include "imm/trainer/fcm/fcm_trainer.hpp"

namespace imm::evaluation {

/// The four figures, in the order of FcmImmOutcome::figures.
inline constexpr const char* kFcmImmFigures[4] = {"pos_rmse", "vel_rmse", "pos_rmse_maneuver",
                                                  "vel_rmse_maneuver"};

/// One filter's figures over the test tracks.
struct FcmImmOutcome {
  std::string name;
  double figures[4] = {};  ///< kFcmImmFigures
  /// Per track: Σ squared errors and the sample count, for each figure (tracks × 8).
  Eigen::MatrixXd per_track;
  Eigen::VectorXd position_rmse, velocity_rmse;  ///< per scan, over tracks
  /// FCM filters: the mean manoeuvre fraction Σ_j μ_j (1 − u_noise,j) (both axes), outside and
  /// inside the maneuvers, and per scan; NaN for the others.
  double fraction_straight = std::numeric_limits<double>::quiet_NaN();
  double fraction_maneuver = std::numeric_limits<double>::quiet_NaN();
  Eigen::VectorXd fraction;
  Eigen::MatrixXd first_run;  ///< steps × 4 estimates of track 0 (x, vx, y, vy)
  long failed_steps = 0;
  ConsistencySummary position_nees, nis;
  Eigen::MatrixXd run_position_nees;  ///< runs × scans (NaN where a scan has no sample)

  /// Figure `figure` as a headline metric (its per-track terms).
  [[nodiscard]] HeadlineMetric headline(int figure) const {
    const Eigen::Index column = Eigen::Index{2} * figure;
    return rms_metric(kFcmImmFigures[figure], per_track.col(column), per_track.col(column + 1));
  }
  /// Figure `figure` as a bootstrap statistic.
  [[nodiscard]] Statistic statistic(int figure) const { return headline(figure).statistic(); }
};

/// Runs `make()` over every track of `data` (plots of σ `sigma` per axis) and scores it.
[[nodiscard]] FcmImmOutcome run_fcm_imm_filter(const std::string& name,
                                               const trainer::fcm::FilterFactory& make,
                                               const datasets::TrackSet& data, double sigma);

}  // namespace imm::evaluation
