// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Model files of kind "mlp_input_estimator" (seed 001).
///
///   /mlp                 \@layer_count, \@output_scale > 0, \@output_bias (trained no-maneuver
///   mean),
///                        \@sign (positive|innovation; absent: positive)
///   /mlp/layer`<i>`        \@activation (sigmoid|linear); /weights (out × in), /bias (out)
///   /features            \@definition (text), /input_mean (2), /input_scale (2, > 0)
///   /cv_kf               \@sample_period > 0, \@process_noise ≥ 0, \@measurement_variance > 0
///   /training/loss       epochs × 3 (epoch, training MSE, validation MSE), optional

#include <filesystem>

#include "imm/filters/mlp_input_estimator.hpp"
#include "imm/io/model_file.hpp"
#include "imm/runtime_export.hpp"

namespace imm::io {

/// The model_kind of input-estimator model files.
inline constexpr std::string_view kMlpInputEstimatorKind = "mlp_input_estimator";
/// The feature recipe stored in /features\@definition.
inline constexpr std::string_view kFeatureDefinition =
    "ino(k) = nu(k)^2 / S(k) of the CV KF; sum(k) = 0.1 * sum_{i=0..9} ino(k-i); "
    "diff(k) = ino(k) - ino(k-10); missing ino before the 10th scan = 1; "
    "network input = (feature - input_mean) / input_scale";

/// Writes the model; `loss_curves` (optional, epochs × 3) goes to /training/loss.
IMM_RUNTIME_EXPORT void write_mlp_input_estimator(ModelFileWriter& writer,
                                                  const MlpInputEstimatorModel& model,
                                                  const Eigen::MatrixXd& loss_curves = {});
/// Reads and validates an input-estimator model; FileError names the file and the field.
[[nodiscard]] IMM_RUNTIME_EXPORT MlpInputEstimatorModel
read_mlp_input_estimator(const ModelFileReader& reader);
/// Opens the file and reads it as read_mlp_input_estimator(const ModelFileReader&).
[[nodiscard]] IMM_RUNTIME_EXPORT MlpInputEstimatorModel
read_mlp_input_estimator(const std::filesystem::path& path);

}  // namespace imm::io
