#pragma once
/// `imm-eval fimm`: seed 002's experiment (Table 1, Fig. 6–8). The vehicle cut-in through the
/// distorted range sensor for R = 0.1², 0.5², 1², 2² (I), 100 Monte Carlo runs per row; on
/// identical plots the baseline IMM (h = identity), the FIMM (EKF through the learned TSK sensor
/// model) and the FIMM with the iterated EKF update. Position MSE over runs and scans (ξ and η
/// errors squared and summed), and the position NEES of each filter (2 when consistent).

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace imm::evaluation {

struct FimmExperimentOptions {
  std::filesystem::path model;   ///< tsk_sensor model file
  std::filesystem::path config;  ///< the TSK config: true distortion, [fimm], [scenario]
  int runs = 100;
  std::uint64_t seed = 1;
  std::vector<double> r_sigmas = {0.1, 0.5, 1.0, 2.0};  ///< √R per row, m
};

struct FimmFilterScore {
  double mse = 0.0;           ///< position MSE, m²
  double nees = 0.0;          ///< mean position NEES
  Eigen::MatrixXd first_run;  ///< steps × 2: run 0's (ξ̂, η̂)
  long failed_steps = 0;
  double outside_box = 0.0;  ///< share of steps with the estimate outside the sensor box
  Eigen::VectorXd scan_mse;  ///< steps: position MSE over runs per scan (NaN before scoring)
  /// MSE over the scans where the true sensor is flat in range (dη_m/dη < kFlatSlope) and over
  /// the others (NaN when there are none).
  double mse_flat = 0.0, mse_steep = 0.0;
};

/// Below this range slope dη_m/dη the sensor counts as flat (the measured range changes by less
/// than half the true change).
inline constexpr double kFlatSlope = 0.5;

struct FimmRow {
  double r_sigma = 0.0;
  FimmFilterScore imm, fimm, fimm_iekf;
  Eigen::MatrixXd first_measurements;  ///< steps × 2
};

struct FimmExperimentResult {
  int runs = 0, steps = 0;
  std::uint64_t seed = 0;
  double softness = 0.0;  ///< the true sensor's L
  std::string fimm_settings;
  Eigen::MatrixXd truth;        ///< steps × 6
  Eigen::VectorXd range_slope;  ///< steps: dη_m/dη of the true sensor at the true position
  int flat_scans = 0;           ///< scored scans with range_slope < kFlatSlope
  std::vector<FimmRow> rows;
  /// The sensor model against the data along the road (ξ = 0 and ξ = lane offset): η, the true
  /// distorted range, the model's z₂, and z₁ at the lane offset (true, model).
  Eigen::MatrixXd sensor_curve;
  Eigen::MatrixXd sensor_samples;  ///< a subset of the data set: η, z₂
};

[[nodiscard]] FimmExperimentResult run_fimm_experiment(const FimmExperimentOptions& options);

/// The paper's Table 1 (IMM, FIMM) for R = 0.1², 0.5², 1², 2².
inline constexpr double kSeed002Table1[4][2] = {
    {10.0795, 1.1752}, {10.9410, 2.0137}, {11.4160, 2.4189}, {5.9691, 13.3480}};

}  // namespace imm::evaluation
