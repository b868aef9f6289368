// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Back-propagation for the input estimator's MLP, written here with Eigen and plain loops (no ML
/// framework). The network is the runtime's (imm/models/learned/mlp.hpp): layers a = f(W x + b),
/// output y = scale × a_L. Training works in the output unit's own range: the target t becomes t /
/// scale and the loss is E = ½ (a_L − t/scale)² per sample, the classic formulation the seed's
/// learning rates (0.1, then 0.05 / 0.01) are meant for. Reported losses are MSEs in the target's
/// unit, scale² × 2E.
///
/// Output unit, and why: a sigmoid scaled to [0, scale] (default 12 m/s², above the 10 m/s² of the
/// training maneuvers). Its output is bounded and non-negative like the seed's maneuvers, and its
/// gradient stays O(1) in the normalized units, so the seed's rate 0.1 trains stably. A linear unit
/// on raw m/s² multiplies the output delta by the target's scale and at 0.1 diverges or collapses
/// to a constant; it remains available ("linear", trained on the same normalized target).

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <vector>

#include "imm/models/learned/mlp.hpp"

namespace imm::trainer::mlp {

struct Samples {
  Eigen::MatrixXd inputs;   ///< n × input count
  Eigen::VectorXd targets;  ///< n, in the output's unit (m/s²)
};

struct Phase {
  int epochs = 3000;
  double hidden_rate = 0.1;  ///< learning rate of every layer but the last
  double output_rate = 0.1;  ///< learning rate of the output layer
};

enum class UpdateMode { kPerSample, kBatch };
enum class Optimizer { kGradientDescent, kAdam };

struct LossPoint {
  int epoch = 0;
  double training = 0.0, validation = 0.0;  ///< MSE, target unit
};

struct TrainingOptions {
  std::vector<Phase> phases = {{3000, 0.1, 0.1}, {3000, 0.05, 0.01}};
  UpdateMode mode = UpdateMode::kPerSample;
  Optimizer optimizer = Optimizer::kGradientDescent;
  int loss_every = 50;     ///< epochs between loss-curve points
  std::uint64_t seed = 1;  ///< sample order (per-sample mode)
  /// Called with each point of the loss curve as it is measured (progress; may be empty).
  std::function<void(const LossPoint&)> on_point;
};

/// A trainable copy of an MLP's parameters.
class Network {
 public:
  /// Layer sizes {inputs, hidden…, 1}; hidden units sigmoid; weights uniform in ±init_range.
  Network(const std::vector<int>& sizes, Activation output, double output_scale, double init_range,
          std::uint64_t seed);
  explicit Network(const Mlp& mlp);

  [[nodiscard]] Mlp to_mlp() const { return {layers_, output_scale_}; }
  [[nodiscard]] double predict(const double* input) const;
  /// Mean squared error in the target's unit.
  [[nodiscard]] double mse(const Samples& samples) const;
  /// ∂E/∂(W, b) of the batch loss E = mean ½ (a_L − t/scale)² (not thread-safe: the network
  /// keeps the batch workspace). A 2-10-10-1 network with sigmoid hidden layers takes one fused
  /// pass over the samples in vector lanes, spread over the OpenMP threads in a fixed number of
  /// chunks (the same bits at any thread count; batch_gradients.hpp); every other shape the
  /// matrix products of gradients_general. They differ by rounding.
  void gradients(const Samples& samples, std::vector<Eigen::MatrixXd>& weights,
                 std::vector<Eigen::VectorXd>& biases) const;
  /// gradients() by matrix products over the whole batch, for any shape (public for the test
  /// that compares the two).
  void gradients_general(const Samples& samples, std::vector<Eigen::MatrixXd>& weights,
                         std::vector<Eigen::VectorXd>& biases) const;
  /// One back-propagation update on one sample (per-layer learning rates). A 2-10-10-1 network
  /// with sigmoid hidden layers (the input estimator's) takes a path with its sizes known to the
  /// compiler; every other shape the general one. Both give the same bits.
  void update_on_sample(const double* input, double target, double hidden_rate, double output_rate);
  /// The general path of update_on_sample, for any shape (public for the test that compares them).
  void update_general(const double* input, double target, double hidden_rate, double output_rate);

  [[nodiscard]] std::vector<MlpLayer>& layers() { return layers_; }
  [[nodiscard]] const std::vector<MlpLayer>& layers() const { return layers_; }
  [[nodiscard]] double output_scale() const { return output_scale_; }

 private:
  void forward(const double* input) const;  // fills activations_

  std::vector<MlpLayer> layers_;
  double output_scale_ = 1.0;
  mutable std::vector<std::vector<double>> activations_;
  mutable std::vector<std::vector<double>> deltas_;
  mutable std::vector<Eigen::MatrixXd> batch_activations_;  // gradients(): n × units per layer
  mutable std::vector<Eigen::MatrixXd> batch_deltas_;
};

/// Trains `network` with the phases of `options`; returns the loss curve (epoch 0 and every
/// loss_every epochs, and the last).
std::vector<LossPoint> train(Network& network, const Samples& training, const Samples& validation,
                             const TrainingOptions& options);

}  // namespace imm::trainer::mlp
