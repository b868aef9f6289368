// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Model files of kind "wimm": the parameters of a weighted IMM (seed 004).
///
///   /wimm   \@sample_period, \@cv_process_noise, \@singer_tau, \@singer_sigma, \@range_sigma,
///           \@azimuth_sigma (rad), \@threshold, \@alpha (0, 1], \@fusion (none|seed|correlated),
///           \@update (extended|converted), \@acceleration_variance
///   /wimm/transition             2×2 (CV, Singer), rows sum to 1
///   /wimm/initial_probabilities  2

#include <filesystem>

#include "imm/filters/wimm.hpp"
#include "imm/io/model_file.hpp"
#include "imm/runtime_export.hpp"

namespace imm::io {

/// The model_kind of WIMM model files.
inline constexpr std::string_view kWimmKind = "wimm";

/// Writes the spec's datasets and attributes (provenance is the writer's).
IMM_RUNTIME_EXPORT void write_wimm(ModelFileWriter& writer, const WimmSpec& spec);
/// Reads and validates a WIMM model; FileError names the file and the field.
[[nodiscard]] IMM_RUNTIME_EXPORT WimmSpec read_wimm(const ModelFileReader& reader);
/// Opens the file and reads it as read_wimm(const ModelFileReader&).
[[nodiscard]] IMM_RUNTIME_EXPORT WimmSpec read_wimm(const std::filesystem::path& path);

}  // namespace imm::io
