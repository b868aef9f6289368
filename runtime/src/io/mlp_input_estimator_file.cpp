// SPDX-License-Identifier: Apache-2.0
#include "imm/io/mlp_input_estimator_file.hpp"

#include <cmath>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"

namespace imm::io {
namespace {
std::string layer_group(std::size_t i) { return "/mlp/layer" + std::to_string(i); }
}  // namespace

void write_mlp_input_estimator(ModelFileWriter& writer, const MlpInputEstimatorModel& model,
                               const Eigen::MatrixXd& loss_curves) {
  const auto& layers = model.network.layers();
  writer.set_attribute("/mlp", "layer_count", static_cast<std::int64_t>(layers.size()));
  const UnitNames& u = writer.units();
  // The network's output, times output_scale plus output_bias, is the input estimate û: an
  // acceleration.
  writer.set_quantity("/mlp", "output_scale", model.network.output_scale(), u.acceleration());
  writer.set_quantity("/mlp", "output_bias", model.output_bias, u.acceleration());
  writer.set_attribute("/mlp", "sign", std::string(to_string(model.sign)));
  if (model.input_variance > 0.0) {
    // A reader that does not know it would run the seed's filter: schema 3.
    writer.set_quantity("/mlp", "input_variance", model.input_variance, u.acceleration_variance());
    writer.require_schema_version(3);
  }
  for (std::size_t i = 0; i < layers.size(); ++i) {
    writer.set_attribute(layer_group(i), "activation",
                         std::string(to_string(layers[i].activation)));
    const Eigen::MatrixXd& weights = layers[i].weights;
    std::vector<std::string> inputs;
    for (Eigen::Index c = 0; c < weights.cols(); ++c) {
      inputs.push_back(i == 0 ? (c == 0 ? "sum" : "diff") : "unit" + std::to_string(c));
    }
    writer.write_matrix(layer_group(i) + "/weights", weights, inputs, kDimensionless);
    writer.write_vector(layer_group(i) + "/bias", layers[i].bias, kDimensionless);
  }
  writer.set_attribute("/features", "definition", std::string(kFeatureDefinition));
  writer.write_vector("/features/input_mean", model.input_mean, kDimensionless);
  writer.write_vector("/features/input_scale", model.input_scale, kDimensionless);
  writer.set_quantity("/cv_kf", "sample_period", model.settings.sample_period, "s");
  writer.set_quantity("/cv_kf", "process_noise", model.settings.process_noise,
                      u.acceleration_variance());
  writer.set_quantity("/cv_kf", "measurement_variance", model.settings.measurement_variance,
                      u.area());
  if (loss_curves.size() > 0) {
    // The training targets are the network's outputs before output_scale: dimensionless.
    writer.write_matrix("/training/loss", loss_curves, {"epoch", "training_mse", "validation_mse"},
                        kDimensionless);
  }
}

MlpInputEstimatorModel read_mlp_input_estimator(const ModelFileReader& reader) {
  MlpInputEstimatorModel model;
  const auto count = reader.integer("/mlp", "layer_count", 1, 16);
  std::vector<MlpLayer> layers;
  for (std::int64_t i = 0; i < count; ++i) {
    const std::string group = layer_group(static_cast<std::size_t>(i));
    MlpLayer layer;
    const std::string activation = reader.text(group, "activation");
    try {
      layer.activation = value_named(kActivationNames, activation, "activation", "activation");
    } catch (const InvalidParameter& error) {
      reader.fail(group + "@activation", error.message());
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
  if (reader.container().attribute("/mlp", "input_variance")) {
    model.input_variance = reader.real("/mlp", "input_variance", ValueRule::kNonNegative);
    if (!limits::contains(limits::kVariance, model.input_variance)) {
      reader.fail("/mlp@input_variance", "must be in " + limits::describe(limits::kVariance));
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
  reader.require_units_of_reals();
  return model;
}

MlpInputEstimatorModel read_mlp_input_estimator(const std::filesystem::path& path) {
  return read_mlp_input_estimator(ModelFileReader(path, kMlpInputEstimatorKind));
}

}  // namespace imm::io
