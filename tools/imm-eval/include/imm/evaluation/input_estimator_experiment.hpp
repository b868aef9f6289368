#pragma once
/// `imm-eval input-estimator`: seed 001's experiments (Tables 1 and 2). One axis, T = 1 s,
/// σ_z = 50 m, 300 s runs starting at 100 m/s, the first maneuver at 100 s (the second, in
/// experiment 2, 70 s after the first ends). Per row, 100 Monte Carlo runs with identical noise for
/// the constant-velocity KF and the corrected KF (the same plots feed both), and as a floor the
/// primary KF fed the true acceleration. MSE of the innovation, the position and the velocity over
/// every scan after the two-point start and every run.

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace imm::evaluation {

struct InputEstimatorOptions {
  std::filesystem::path model;
  int runs = 100;
  std::uint64_t seed = 1;
};

struct KfErrors {
  double innovation_mse = 0.0, position_mse = 0.0, velocity_mse = 0.0;
};

struct InputEstimatorRow {
  int experiment = 1;
  std::string name;  ///< "5 m/s2 30 s"
  KfErrors cv, corrected, true_input;
  KfErrors paper_cv, paper_corrected;
  Eigen::VectorXd true_acceleration, mean_estimate;           ///< per scan (mean over runs)
  Eigen::VectorXd cv_position_rmse, corrected_position_rmse;  ///< per scan
};

[[nodiscard]] std::vector<InputEstimatorRow> run_input_estimator_experiment(
    const InputEstimatorOptions& options);

}  // namespace imm::evaluation
