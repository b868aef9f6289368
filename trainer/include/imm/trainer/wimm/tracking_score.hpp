// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Scores of a weighted/normal IMM over polar Monte Carlo data (seed 004 §4): azimuth error of the
/// combined estimate (radians, wrapped), position error and the NEES of the 4-D position–velocity
/// state, as RMSE over runs per scan and their averages over all scans with an estimate and over
/// the settled scans 41–250 (the seed's first 40 scans are its settling phase). Used by the trainer
/// (tuning objective, on the regime's training split) and by imm-eval (on its test split).

#include <Eigen/Core>
#include <vector>

#include "imm/datasets/track.hpp"
#include "imm/filters/wimm.hpp"

namespace imm::trainer::wimm {

inline constexpr int kFirstSettledScan = 40;  ///< 0-based: scans 41–250 of the seed
/// The first settled scan of a track of `scans`: the seed's 40, or a fifth of a shorter track.
[[nodiscard]] int first_settled_scan(int scans);

struct TrackingScore {
  Eigen::VectorXd azimuth_rmse;                 ///< per scan (NaN before the first estimate)
  Eigen::VectorXd position_rmse;                ///< per scan, m
  Eigen::VectorXd mean_nees;                    ///< per scan, averaged over runs
  Eigen::VectorXd fused_fraction;               ///< per scan, share of runs that fused the azimuth
  Eigen::MatrixXd mean_mode_probabilities;      ///< steps × 2 (CV, Singer)
  double azimuth = 0.0, azimuth_settled = 0.0;  ///< averages of azimuth_rmse
  double position = 0.0, position_settled = 0.0;  ///< averages of position_rmse
  double nees_settled = 0.0;                      ///< average NEES, settled scans
  /// Per track: mean squared azimuth error (rad²) and position error (m²) over its settled scans —
  /// the Monte Carlo samples a comparison's uncertainty is computed from.
  Eigen::VectorXd track_azimuth_settled, track_position_settled;
  /// tracks × scans: the position NEES and the NIS of the polar plot (normalized_errors.hpp) where
  /// the track has an estimate, resp. an update; NaN elsewhere. For the consistency table.
  Eigen::MatrixXd run_position_nees, run_nis;
};

/// How well a filter predicts the plots, with no truth (a recorded regime's plots alone): over
/// every plot the filter updated with, summed in track order.
struct PlotScore {
  /// −1/N Σ log p(z | Z^(k−1)) (WimmFilter::log_predictive_likelihood: the density of the plot,
  /// not of a fused azimuth) minus the plot noise's own entropy ½ log((2πe)² σ_r² σ_θ²): 0 for a
  /// filter that knew every position; lower is better.
  double excess_nll = 0.0;
  /// √(1/N Σ ν_r²/σ_r² + ν_θ²/σ_θ²) of the plot's innovation: in plot σ, so range and azimuth
  /// weigh alike.
  double innovation_rms = 0.0;
  long plots = 0;  ///< N
};

/// Runs `spec` over every track of `data` and scores its prediction of the plots (the figures
/// are `max()` when a filter predicts a plot with zero density).
[[nodiscard]] PlotScore score_plots(const WimmSpec& spec, const datasets::TrackSet& data);

/// Runs `spec` over every track of `data` (polar plots of a sensor at `sensor_position`).
[[nodiscard]] TrackingScore score_tracking(const WimmSpec& spec, const datasets::TrackSet& data,
                                           const Eigen::Vector2d& sensor_position);

}  // namespace imm::trainer::wimm
