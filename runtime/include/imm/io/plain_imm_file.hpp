// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Model files of kind "plain_imm": a PlainImmSpec frozen into the model-file schema.
///
///   /imm                    \@sample_period, \@mode_count
///   /imm/transition         N×N, probabilities, rows sum to 1
///   /imm/initial_probabilities  N
///   /imm/modes/mode`<i>`      \@name, \@motion (cv|ca|singer), \@noise_form, \@process_noise ≥ 0,
///                           \@tau > 0, \@sigma_a ≥ 0
///   /measurement            \@kind (cartesian|polar)
///   /measurement/covariance 2×2
///   /initialization         \@method (explicit|two_point), \@acceleration_variance ≥ 0
///   /initialization/state, /initialization/covariance   (explicit only)

#include <filesystem>

#include "imm/filters/plain_imm.hpp"
#include "imm/io/model_file.hpp"
#include "imm/runtime_export.hpp"

namespace imm::io {

/// The model_kind of plain IMM model files.
inline constexpr std::string_view kPlainImmKind = "plain_imm";

/// Writes the spec's datasets and attributes (provenance is the writer's).
IMM_RUNTIME_EXPORT void write_plain_imm(ModelFileWriter& writer, const PlainImmSpec& spec);

/// Reads and validates a plain_imm model; FileError names the file and the field.
[[nodiscard]] IMM_RUNTIME_EXPORT PlainImmSpec read_plain_imm(const ModelFileReader& reader);
/// Opens the file and reads it as read_plain_imm(const ModelFileReader&).
[[nodiscard]] IMM_RUNTIME_EXPORT PlainImmSpec read_plain_imm(const std::filesystem::path& path);

}  // namespace imm::io
