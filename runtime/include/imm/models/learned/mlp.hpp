// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// A multilayer perceptron (seed 001 Fig. 2: 2-10-10-1, sigmoid hidden units, biases). Each layer
/// computes a = f(W x + b); the network's output is output_scale × (last layer's activation), so a
/// sigmoid output unit covers [0, output_scale]. The runtime evaluates one input at a time without
/// allocating (buffers sized at construction; not thread-safe). The trainer back-propagates through
/// these same layers (trainer/…/mlp/backpropagation.hpp).

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "imm/core/enum_names.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// A layer's activation function.
enum class Activation { kSigmoid, kLinear };

/// Each activation with its name in model files (core/enum_names.hpp).
inline constexpr std::array kActivationNames{EnumName<Activation>{Activation::kSigmoid, "sigmoid"},
                                             EnumName<Activation>{Activation::kLinear, "linear"}};

/// "sigmoid" | "linear".
[[nodiscard]] constexpr std::string_view to_string(Activation activation) {
  return name_of(kActivationNames, activation);
}

/// f(x).
[[nodiscard]] inline double activate(Activation activation, double x) {
  return activation == Activation::kSigmoid ? 1.0 / (1.0 + std::exp(-x)) : x;
}

/// f'(x) expressed through a = f(x).
[[nodiscard]] inline double activation_derivative(Activation activation, double a) {
  return activation == Activation::kSigmoid ? a * (1.0 - a) : 1.0;
}

/// One fully connected layer: a = f(W x + b).
struct IMM_RUNTIME_EXPORT MlpLayer {
  Eigen::MatrixXd weights;  ///< outputs × inputs
  Eigen::VectorXd bias;     ///< outputs
  /// f.
  Activation activation = Activation::kSigmoid;
};

/// A multilayer perceptron whose output is scaled by output_scale (seed 001's network).
class IMM_RUNTIME_EXPORT Mlp {
 public:
  Mlp() = default;

  /// Throws std::invalid_argument naming the layer for inconsistent shapes or non-finite values.
  Mlp(std::vector<MlpLayer> layers, double output_scale)
      : layers_(std::move(layers)), output_scale_(output_scale) {
    if (layers_.empty()) throw std::invalid_argument("an MLP needs at least one layer");
    if (!std::isfinite(output_scale_) || output_scale_ <= 0.0) {
      throw std::invalid_argument("output_scale must be positive and finite");
    }
    for (std::size_t i = 0; i < layers_.size(); ++i) {
      const MlpLayer& layer = layers_[i];
      const std::string name = "layer " + std::to_string(i);
      if (layer.weights.rows() < 1 || layer.weights.cols() < 1 ||
          layer.bias.size() != layer.weights.rows()) {
        throw std::invalid_argument(name + ": weights and bias shapes disagree");
      }
      if (i > 0 && layer.weights.cols() != layers_[i - 1].weights.rows()) {
        throw std::invalid_argument(name + ": " + std::to_string(layer.weights.cols()) +
                                    " inputs, previous layer has " +
                                    std::to_string(layers_[i - 1].weights.rows()) + " outputs");
      }
      if (!layer.weights.allFinite() || !layer.bias.allFinite()) {
        throw std::invalid_argument(name + ": non-finite weights");
      }
    }
    if (layers_.back().weights.rows() != 1) {
      throw std::invalid_argument("the output layer must have one unit");
    }
    buffers_.reserve(layers_.size());
    for (const MlpLayer& layer : layers_) buffers_.emplace_back(layer.weights.rows());
  }

  /// The scalar output for `input` (input_count() values).
  [[nodiscard]] double forward(const Eigen::Ref<const Eigen::VectorXd>& input) const {
    const Eigen::VectorXd* x = nullptr;
    for (std::size_t i = 0; i < layers_.size(); ++i) {
      const MlpLayer& layer = layers_[i];
      Eigen::VectorXd& a = buffers_[i];
      if (i == 0) {
        a.noalias() = layer.weights * input;
      } else {
        a.noalias() = layer.weights * *x;
      }
      a += layer.bias;
      for (Eigen::Index j = 0; j < a.size(); ++j) a(j) = activate(layer.activation, a(j));
      x = &a;
    }
    // A default-constructed network has no layers and no output (the filters refuse it).
    if (x == nullptr) return std::numeric_limits<double>::quiet_NaN();
    return output_scale_ * (*x)(0);
  }

  /// The number of inputs of the first layer.
  [[nodiscard]] int input_count() const {
    return layers_.empty() ? 0 : static_cast<int>(layers_.front().weights.cols());
  }
  /// The layers, input first.
  [[nodiscard]] const std::vector<MlpLayer>& layers() const { return layers_; }
  /// The factor the last layer's output is multiplied by.
  [[nodiscard]] double output_scale() const { return output_scale_; }

 private:
  std::vector<MlpLayer> layers_;
  double output_scale_ = 1.0;
  mutable std::vector<Eigen::VectorXd> buffers_;
};

}  // namespace imm
