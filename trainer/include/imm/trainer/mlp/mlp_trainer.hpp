#pragma once
/// `imm-train mlp --config configs/mlp_input_estimator.toml`: the neural input estimator of seed
/// 001. Training data: one-axis trajectories from the configured acceleration profiles (the seed's
/// §4.1: initial speed 100 m/s, 500 s, accelerations in 0–10 m/s² with different durations), noisy
/// measurements, and the features of the runtime's own InnovationFeatureExtractor; target = the
/// true acceleration. Inputs are standardized with the training features' mean and standard
/// deviation (stored in the model).
///
/// The no-maneuver bias: the first scans of every maneuver look like straight flight, so a
/// squared-error fit averages their targets into the quiet region and outputs a positive value
/// without a maneuver. It is measured at training time — the network's mean output on a
/// maneuver-free trajectory — stored as output_bias, and subtracted (then clipped at 0) by the
/// runtime. Nothing is chosen on evaluation data.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "imm/filters/input_estimation_filter.hpp"
#include "imm/trainer/mlp/network_training.hpp"

namespace imm::trainer::mlp {

struct ManeuverPulse {
  double start = 0.0;         ///< s
  double duration = 0.0;      ///< s
  double acceleration = 0.0;  ///< m/s²
};

struct MlpTrainingConfig {
  std::uint64_t seed = 1;
  CvKfSettings cv_kf{1.0, 1.0, 2500.0};
  double initial_speed = 100.0;
  double duration = 500.0;  ///< s per trajectory
  int realizations = 1;     ///< noise draws per profile
  std::vector<std::vector<ManeuverPulse>> training_profiles;
  std::vector<std::vector<ManeuverPulse>> validation_profiles;
  double quiet_duration = 500.0;  ///< the maneuver-free trajectory of the bias
  std::vector<int> hidden = {10, 10};
  Activation output = Activation::kSigmoid;
  double output_scale = 12.0;
  double init_range = 0.5;
  TrainingOptions training;
  double max_validation_rmse = 3.0;  ///< quality gate, m/s²

  std::string text, name;

  void validate() const;  ///< InvalidParameter naming the key
};

[[nodiscard]] MlpTrainingConfig load_mlp_config(const std::filesystem::path& path);

/// One trajectory's samples: standardized later.
struct FeatureSet {
  Samples samples;  ///< raw features (sum, diff) and true accelerations
  std::string digest;
};

/// Features and targets of the given profiles (each `realizations` times), via the runtime's
/// feature extractor.
[[nodiscard]] FeatureSet make_features(const MlpTrainingConfig& config,
                                       const std::vector<std::vector<ManeuverPulse>>& profiles,
                                       std::uint64_t stream);

struct MlpTrainingResult {
  InputEstimatorModel model;
  std::vector<LossPoint> loss;
  double training_rmse = 0.0, validation_rmse = 0.0;  ///< m/s², of the trained network
  double bias_before = 0.0;  ///< mean output without a maneuver (held-out quiet trajectory)
  double bias_after = 0.0;   ///< the same after subtracting output_bias and clipping
  double wall_seconds = 0.0;
  double training_seconds = 0.0;  ///< back-propagation alone
  bool gate_passed = false;
  std::string digest;
};

/// Trains; writes the model and metrics when the gate passes.
MlpTrainingResult train_mlp(const MlpTrainingConfig& config, const std::filesystem::path& out);

}  // namespace imm::trainer::mlp
