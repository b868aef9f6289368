#pragma once
/// `imm-eval fcm-imm`: seed 003's experiment (Fig. 5–8). On identical Monte Carlo noise over the
/// seed-003 scenario: a single CV KF with q tuned (KF), the adaptive IMM tuned (AIMM), the
/// constant-q IMM tuned (IMM-tuned), the learned FCM-IMM, and the same FCM-IMM with its
/// memberships replaced by their training means (FCM-IMM-const, the ablation). The baselines are
/// tuned on the FCM config's training trajectories with the trainer's objective — never on the
/// evaluation runs.

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace imm::evaluation {

struct FcmImmExperimentOptions {
  std::filesystem::path model;            ///< fcm_imm model file
  std::filesystem::path training_config;  ///< FCM config: training trajectories for the tuning
  int runs = 100;
  std::uint64_t seed = 1;
  double acceleration_scale = 1.0;  ///< 10: the seed's literal 0.3–0.6 km/s²
};

struct FcmFilterOutcome {
  std::string name;
  double pos_rmse = 0.0, vel_rmse = 0.0;                    ///< scans 2 … 399
  double pos_rmse_maneuver = 0.0, vel_rmse_maneuver = 0.0;  ///< the zigzag's scans
  Eigen::VectorXd position_rmse, velocity_rmse;             ///< per scan, over runs
  /// FCM filters: the mean manoeuvre fraction Σ_j μ_j (1 − u_noise,j) (both axes) outside and
  /// inside the manoeuvre, and per scan; NaN for the others.
  double fraction_straight = 0.0, fraction_maneuver = 0.0;
  Eigen::VectorXd fraction;
  Eigen::MatrixXd first_run;  ///< steps × 4 estimates of run 0 (x, vx, y, vy)
  long failed_steps = 0;
};

struct FcmImmExperimentResult {
  int runs = 0, steps = 0;
  std::uint64_t seed = 0;
  double acceleration_scale = 1.0;
  int maneuver_first = 0, maneuver_end = 0;  ///< scans [first, end)
  std::string dataset_digest;
  std::vector<FcmFilterOutcome> filters;          ///< KF, AIMM, IMM-tuned, FCM-IMM, FCM-IMM-const
  std::map<std::string, std::string> parameters;  ///< tuned / fitted parameters, for the report
  std::map<std::string, double> training_objective;
  Eigen::MatrixXd first_truth, first_measurements;  ///< run 0
  /// Run 0, FCM-IMM, x axis, highest-noise mode: scan, error e(k), its dominant cluster (0 dec,
  /// 1 noise, 2 acc) — seed Fig. 6.
  Eigen::MatrixXd first_clusters;
};

[[nodiscard]] FcmImmExperimentResult run_fcm_imm_experiment(const FcmImmExperimentOptions& options);

}  // namespace imm::evaluation
