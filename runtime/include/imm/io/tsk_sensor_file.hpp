// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Model files of kind "tsk_sensor": a probabilistic TSK model of a range sensor (seed 002).
///
///   /tsk            \@t_norm (min|product), \@inputs = "xi,eta", \@outputs = "z1,z2"
///   /tsk/input_box  2 × 2: row 0 the lower, row 1 the upper bound of (ξ, η) seen in training
///   /tsk/output`<i>`/rules   c × 7 (i = 1, 2): center_xi, width_xi, center_eta, width_eta,
///                          a0, a_xi, a_eta;  \@sigma ≥ 0 on /tsk/output`<i>`
///   /fimm           the FIMM the model was evaluated in (fimm.hpp): \@sample_period (s),
///                   \@cruise_sigma, \@lane_change_ratio, \@noise_scale, \@iterations (integer),
///                   \@acceleration_variance; /fimm/transition 2 × 2, /fimm/initial_probabilities
///                   2, /fimm/measurement_covariance 2 × 2 (the regime's first case). Absent in
///                   files written before the settings were stored: their FIMM settings are the
///                   [fimm] table of the training config.
/// The training data's digest is the root attribute dataset_digest.

#include <filesystem>
#include <optional>

#include "imm/filters/fimm.hpp"
#include "imm/io/model_file.hpp"
#include "imm/models/learned/tsk_sensor_model.hpp"
#include "imm/runtime_export.hpp"

namespace imm::io {

/// The model_kind of TSK sensor model files.
inline constexpr std::string_view kTskSensorKind = "tsk_sensor";

/// Writes the sensor model (/tsk).
IMM_RUNTIME_EXPORT void write_tsk_sensor(ModelFileWriter& writer, const TskSensorModel& model);
/// Reads and validates a TSK sensor model; FileError names the file and the field.
[[nodiscard]] IMM_RUNTIME_EXPORT TskSensorModel read_tsk_sensor(const ModelFileReader& reader);
/// Opens the file and reads it as read_tsk_sensor(const ModelFileReader&).
[[nodiscard]] IMM_RUNTIME_EXPORT TskSensorModel read_tsk_sensor(const std::filesystem::path& path);

/// The FIMM settings stored beside the sensor model (/fimm); nullopt when the file has none.
IMM_RUNTIME_EXPORT void write_fimm_settings(ModelFileWriter& writer, const FimmSpec& spec);
/// Reads /fimm; FileError names the field of an invalid setting.
[[nodiscard]] IMM_RUNTIME_EXPORT std::optional<FimmSpec> read_fimm_settings(
    const ModelFileReader& reader);

/// A rule set as the c × 7 matrix of the file, and back.
[[nodiscard]] IMM_RUNTIME_EXPORT Eigen::MatrixXd rules_matrix(const std::vector<TskRule>& rules);
/// Throws std::invalid_argument for a matrix that is not c × 7.
[[nodiscard]] IMM_RUNTIME_EXPORT std::vector<TskRule> rules_from_matrix(
    const Eigen::MatrixXd& matrix);

}  // namespace imm::io
