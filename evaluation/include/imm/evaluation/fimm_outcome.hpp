// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The FIMM experiment's Monte Carlo loop (seed 002's figures): a filter per test track, started
/// from its first two plots and scored from scan 2 on by its position MSE (ξ and η errors squared
/// and summed), NEES and NIS, where the true sensor is flat in range and elsewhere, and how often
/// the FIMM's estimate left the sensor model's box. The runs are spread over the job's ranks and
/// summed in run order.

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>

#include "imm/datasets/regime.hpp"
#include "imm/datasets/track.hpp"
#include "imm/evaluation/consistency.hpp"
#include "imm/evaluation/headline.hpp"
#include "imm/evaluation/uncertainty.hpp"
#include "imm/filters/fimm.hpp"

namespace imm::evaluation {

/// Below this range slope dη_m/dη the sensor counts as flat (the measured range changes by less
/// than half the true change).
inline constexpr double kFlatSlope = 0.5;

/// One filter's figures over the tracks of a case.
struct FimmOutcome {
  double mse = 0.0, nees = 0.0;
  double mse_flat = 0.0, mse_steep = 0.0;  ///< where the true sensor is flat in range, elsewhere
  double clamped = 0.0;                    ///< share of steps outside the model's box
  long failed_steps = 0;
  Eigen::MatrixXd per_track;  ///< tracks × 2: Σ squared position error, samples
  Eigen::MatrixXd first_run;  ///< scans × 2: track 0's (ξ̂, η̂)
  Eigen::VectorXd scan_mse;   ///< per scan, over tracks
  /// Position NEES and NIS (of the sensor's (z1, z2)) against their χ² bounds for the runs.
  ConsistencySummary position_nees, nis;
  Eigen::MatrixXd run_position_nees;  ///< runs × scans (NaN where a scan has no sample)

  /// The position MSE as a headline metric named `name` (its per-track terms).
  [[nodiscard]] HeadlineMetric headline(std::string name) const {
    return ratio_metric(std::move(name), per_track.col(0), per_track.col(1));
  }
  /// The position MSE as a bootstrap statistic.
  [[nodiscard]] Statistic statistic() const { return headline("mse").statistic(); }
};

/// Runs `make()` over every track of `data` (the true sensor `sensor`, plot variance r per axis,
/// the start's acceleration variance) and scores it.
[[nodiscard]] FimmOutcome run_fimm_filter(const std::function<std::unique_ptr<FimmFilter>()>& make,
                                          const datasets::TrackSet& data,
                                          const datasets::Sensor& sensor, double r,
                                          double acceleration_variance);

}  // namespace imm::evaluation
