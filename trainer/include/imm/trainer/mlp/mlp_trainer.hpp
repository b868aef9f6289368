// SPDX-License-Identifier: Apache-2.0
#pragma once
/// `imm-train mlp --config configs/mlp_input_estimator.toml`: the neural input estimator of seed
/// 001. Training data: the one-axis trajectories of the regime's training split (every 2-D track
/// gives its x and its y axis), noisy plots, and the features of the runtime's own
/// InnovationFeatureExtractor; target = the magnitude of the axis's true acceleration (the filter
/// takes the sign from the innovations, InputSign::kInnovation, or the seed's always-positive
/// one). Inputs are standardized with the training features' mean and standard deviation (stored
/// in the model).
///
/// The no-maneuver bias: the first scans of every maneuver look like straight flight, so a
/// squared-error fit averages their targets into the quiet region and outputs a positive value
/// without a maneuver. It is measured at training time — the network's mean output on a
/// maneuver-free track of the regime (its start and sensor, no maneuvers) — stored as output_bias,
/// and subtracted (then clipped at 0) by the runtime. Nothing is chosen on evaluation data.
///
/// Without truth (a recorded regime without truth for training) the targets are the accelerations
/// a fixed-interval smoother of the regime's tuned IMM finds in the plots (smoothed_labels.hpp),
/// and the no-maneuver bias is measured on a target at rest seen through the regime's sensor.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "imm/datasets/track.hpp"
#include "imm/filters/axis_cv_imm.hpp"
#include "imm/filters/mlp_input_estimator.hpp"
#include "imm/trainer/mlp/network_training.hpp"

namespace imm::trainer::mlp {

struct MlpTrainingConfig {
  std::uint64_t seed = 1;
  datasets::Regime regime;
  /// The CV KF of the features: T and R are the regime's; q by default (0.1 a)², a the regime's
  /// largest commanded acceleration (the seed's q = 1 (m/s²)² for its 10 m/s²).
  CvKfSettings cv_kf{1.0, 1.0, 2500.0};
  std::vector<int> hidden = {10, 10};
  Activation output = Activation::kSigmoid;
  double output_scale = 12.0;  ///< by default 1.2 a
  double init_range = 0.5;
  InputSign sign = InputSign::kInnovation;
  /// How the model's input_variance σ_û² (the primary KF's q becomes q + σ_û²) is set.
  enum class InputNoise : std::uint8_t {
    kNone,  ///< "none" (the default): 0, the seed's filter, which takes û as exact
    /// "validation": the mean squared error of the filter's signed û against the true
    /// acceleration over the validation split (sign and lag included)
    kValidation,
    /// "consistent": the σ_û² at which the primary KF's mean NIS over the training split is 1,
    /// its dimension (plots only; the input's errors are not white, so the mean squared error
    /// leaves the filter optimistic)
    kConsistent,
  };
  /// [network] input_noise.
  InputNoise input_noise = InputNoise::kNone;
  TrainingOptions training;
  double max_validation_rmse = 3.0;  ///< quality gate (config: × a), regime units

  std::string text, name;

  void validate() const;  ///< InvalidParameter naming the key
};

[[nodiscard]] MlpTrainingConfig load_mlp_config(
    const std::filesystem::path& path,
    const std::optional<std::filesystem::path>& regime = std::nullopt);

/// One trajectory's samples: standardized later.
struct FeatureSet {
  Samples samples;  ///< raw features (sum, diff) and true accelerations
  std::string digest;
};

/// Features and targets of a set of tracks (both axes of each), via the runtime's feature
/// extractor.
[[nodiscard]] FeatureSet make_features(const MlpTrainingConfig& config,
                                       const datasets::TrackSet& tracks);

struct MlpTrainingResult {
  MlpInputEstimatorModel model;
  std::vector<LossPoint> loss;
  double training_rmse = 0.0, validation_rmse = 0.0;  ///< m/s², of the trained network
  double bias_before = 0.0;  ///< mean output without a maneuver (held-out quiet trajectory)
  double bias_after = 0.0;   ///< the same after subtracting output_bias and clipping
  double wall_seconds = 0.0;
  double training_seconds = 0.0;  ///< back-propagation alone
  bool gate_passed = false;
  std::string digest;
  /// Without truth (a recorded regime): the tuned IMM whose smoother labelled the tracks
  /// (smoothed_labels.hpp); empty otherwise.
  std::optional<AxisCvImmSpec> smoother;
};

/// Trains; writes the model and metrics when the gate passes.
MlpTrainingResult train_mlp(const MlpTrainingConfig& config, const std::filesystem::path& out);

}  // namespace imm::trainer::mlp
