// SPDX-License-Identifier: Apache-2.0
#include "imm/io/mlp_input_estimator_file.hpp"

#include <cmath>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"

namespace imm::io {
namespace {
std::string layer_group(std::size_t i) { return "/mlp/layer" + std::to_string(i); }
}  // namespace

void write_mlp_input_estimator(ModelFileWriter& writer, const InputEstimatorModel& model,
                               const Eigen::MatrixXd& loss_curves) {
  const auto& layers = model.network.layers();
  writer.set_attribute("/mlp", "layer_count", static_cast<std::int64_t>(layers.size()));
  writer.set_attribute("/mlp", "output_scale", model.network.output_scale());
  writer.set_attribute("/mlp", "output_bias", model.output_bias);
  writer.set_attribute("/mlp", "sign", std::string(to_string(model.sign)));
  for (std::size_t i = 0; i < layers.size(); ++i) {
    writer.set_attribute(layer_group(i), "activation",
                         std::string(to_string(layers[i].activation)));
    writer.write_matrix(layer_group(i) + "/weights", layers[i].weights);
    writer.write_vector(layer_group(i) + "/bias", layers[i].bias);
  }
  writer.set_attribute("/features", "definition", std::string(kFeatureDefinition));
  writer.write_vector("/features/input_mean", model.input_mean);
  writer.write_vector("/features/input_scale", model.input_scale);
  writer.set_attribute("/cv_kf", "sample_period", model.settings.sample_period);
  writer.set_attribute("/cv_kf", "process_noise", model.settings.process_noise);
  writer.set_attribute("/cv_kf", "measurement_variance", model.settings.measurement_variance);
  if (loss_curves.size() > 0) {
    writer.write_matrix("/training/loss", loss_curves, {"epoch", "training_mse", "validation_mse"});
  }
}

InputEstimatorModel read_mlp_input_estimator(const ModelFileReader& reader) {
  InputEstimatorModel model;
  const auto count = reader.integer("/mlp", "layer_count", 1, 16);
  std::vector<MlpLayer> layers;
  for (std::int64_t i = 0; i < count; ++i) {
    const std::string group = layer_group(static_cast<std::size_t>(i));
    MlpLayer layer;
    const std::string activation = reader.text(group, "activation");
    if (activation == "sigmoid") {
      layer.activation = Activation::kSigmoid;
    } else if (activation == "linear") {
      layer.activation = Activation::kLinear;
    } else {
      reader.fail(group + "@activation", "unknown activation '" + activation + "'");
    }
    const int inputs = i == 0 ? -1 : static_cast<int>(layers.back().weights.rows());
    layer.weights = reader.matrix(group + "/weights", -1, inputs);
    layer.bias = reader.vector(group + "/bias", static_cast<int>(layer.weights.rows()));
    layers.push_back(std::move(layer));
  }
  try {
    model.network =
        Mlp(std::move(layers), reader.real("/mlp", "output_scale", ValueRule::kPositive));
  } catch (const std::invalid_argument& error) {
    reader.fail("/mlp", error.what());
  }
  model.output_bias = reader.real("/mlp", "output_bias");
  // Files written before two-sided regimes carry no sign: the seed's positive one.
  if (reader.container().attribute("/mlp", "sign")) {
    try {
      model.sign = input_sign_from(reader.text("/mlp", "sign"), "sign");
    } catch (const InvalidParameter& error) {
      reader.fail("/mlp@sign", error.message());
    }
  }
  if (model.network.input_count() != 2) reader.fail("/mlp/layer0/weights", "expected 2 inputs");
  model.input_mean = reader.vector("/features/input_mean", 2);
  model.input_scale = reader.vector("/features/input_scale", 2, ValueRule::kPositive);
  model.settings.sample_period = reader.real("/cv_kf", "sample_period", ValueRule::kPositive);
  model.settings.process_noise = reader.real("/cv_kf", "process_noise", ValueRule::kNonNegative);
  model.settings.measurement_variance =
      reader.real("/cv_kf", "measurement_variance", ValueRule::kPositive);
  try {
    model.settings.validate();
  } catch (const InvalidParameter& error) {
    reader.fail("/cv_kf@" + error.field(), error.message());
  }
  // The network's output is an acceleration: scale and bias within the physical range.
  if (!limits::contains(limits::kAcceleration, model.network.output_scale())) {
    reader.fail("/mlp@output_scale", "must be in " + limits::describe(limits::kAcceleration));
  }
  if (!limits::contains(limits::kAcceleration, std::abs(model.output_bias))) {
    reader.fail("/mlp@output_bias",
                "magnitude must be in " + limits::describe(limits::kAcceleration));
  }
  return model;
}

InputEstimatorModel read_mlp_input_estimator(const std::filesystem::path& path) {
  return read_mlp_input_estimator(ModelFileReader(path, kMlpInputEstimatorKind));
}

}  // namespace imm::io
