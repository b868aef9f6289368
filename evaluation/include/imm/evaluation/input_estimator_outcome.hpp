// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The input-estimator experiment's Monte Carlo loop (seed 001's figures): every axis of every
/// test track is one run of the constant-velocity KF, the corrected KF (the network's acceleration
/// fed to the primary KF), IMM-tuned and the primary KF fed the true acceleration, scored after
/// the two-point start. The runs are spread over the job's ranks and summed in run order.

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "imm/datasets/regime.hpp"
#include "imm/datasets/track.hpp"
#include "imm/filters/axis_cv_imm.hpp"
#include "imm/filters/mlp_input_estimator.hpp"

namespace imm::evaluation {

/// The three quantities of each case's MSEs, in column order.
inline constexpr const char* kInputEstimatorQuantities[3] = {"innovation", "position", "velocity"};

/// One case of the regime: its axis runs' figures.
struct InputEstimatorCase {
  std::string name;
  Eigen::MatrixXd cv, corrected, floor;  ///< axis runs × 3 (innovation, position, velocity MSE)
  Eigen::MatrixXd imm;                   ///< axis runs × 3: IMM-tuned (its innovation unused)
  Eigen::VectorXd true_acceleration;     ///< per scan, of the case's first run
  Eigen::VectorXd mean_estimate;         ///< per scan, the mean over runs of the network's û
  Eigen::VectorXd cv_position_rmse, corrected_position_rmse;  ///< per scan
  /// Axis runs × scans: position NEES and NIS (1-D) of the corrected KF, then of IMM-tuned.
  std::array<Eigen::MatrixXd, 4> consistency;
};

/// Runs the four filters over both axes of every track of `data` (the regime's cases, in case
/// order; a case without tracks has no rows).
[[nodiscard]] std::vector<InputEstimatorCase> run_input_estimator_cases(
    const MlpInputEstimatorModel& model, const AxisCvImmSpec& imm_tuned,
    const datasets::Regime& regime, const datasets::TrackSet& data);

}  // namespace imm::evaluation
