// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Model files of kind "fcm_imm": the fitted parameters of an FCM-IMM (seed 003).
///
///   /fcm_imm  \@sample_period, \@measurement_sigma, \@window (integer), \@fuzzifier, \@tolerance,
///             \@max_iterations (integer), \@membership_scale (seed|innovation), \@separation,
///             \@compensation_gain [0, 1], \@compensate_lowest (0|1)
///   /fcm_imm/process_noise          modes, ascending (unit/s²)²
///   /fcm_imm/transition             modes × modes, rows sum to 1
///   /fcm_imm/initial_probabilities  modes
///   /fcm_imm/mean_memberships       modes × 3 (deceleration, noise, acceleration): the mean
///                                   memberships on the training runs, for the constant-membership
///                                   ablation

#include <filesystem>

#include "imm/filters/fcm_imm.hpp"
#include "imm/io/model_file.hpp"
#include "imm/runtime_export.hpp"

namespace imm::io {

/// The model_kind of FCM-IMM model files.
inline constexpr std::string_view kFcmImmKind = "fcm_imm";

/// Writes `spec` (mean_memberships required); constant_memberships is a run-time choice and is
/// not stored.
IMM_RUNTIME_EXPORT void write_fcm_imm(ModelFileWriter& writer, const FcmImmSpec& spec);
/// Reads and validates an FCM-IMM model; FileError names the file and the field.
[[nodiscard]] IMM_RUNTIME_EXPORT FcmImmSpec read_fcm_imm(const ModelFileReader& reader);
/// Opens the file and reads it as read_fcm_imm(const ModelFileReader&).
[[nodiscard]] IMM_RUNTIME_EXPORT FcmImmSpec read_fcm_imm(const std::filesystem::path& path);

}  // namespace imm::io
