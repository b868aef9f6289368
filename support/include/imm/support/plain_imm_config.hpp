// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The TOML form of a plain IMM (configs/track/*.toml). Keys mirror PlainImmSpec:
///
///   units = "m" | "km"     # the length unit of every value (default "m"); frozen model files
///                          # record it (length_unit)
///   sample_period = 1.0
///   transition = [[0.97, 0.015, 0.015], …]        # transition[i][j] = P(j at k | i at k−1)
///   initial_probabilities = [0.6, 0.2, 0.2]
///   [measurement]  kind = "cartesian" | "polar";  covariance = [[…], […]]  or  sigma = [σ₁, σ₂]
///                  (polar: [range, azimuth in radians])
///   [initialization]  method = "two_point" | "explicit";  acceleration_variance = 0.0
///                     state = […], covariance = [[…]]    (explicit only)
///   [[modes]]  name = "…";  motion = "cv" | "ca" | "singer";  process_noise = q
///              noise_form = "piecewise" | "continuous";  tau = …, sigma_a = …  (singer)

#include <filesystem>
#include <memory>

#include "imm/filters/plain_imm.hpp"
#include "imm/support/config.hpp"

namespace imm::support {

/// Reads the spec from `table` (keys relative to it) and validates it.
[[nodiscard]] PlainImmSpec plain_imm_from(const ConfigTable& table);

/// A plain IMM config file: the spec and the length unit its values are in.
struct PlainImmConfig {
  PlainImmSpec spec;
  std::string length_unit = "m";  ///< "m" | "km"
};

/// Loads a whole file holding one plain IMM; unknown keys and invalid values are ConfigErrors.
[[nodiscard]] PlainImmConfig load_plain_imm_file(const std::filesystem::path& path);
/// load_plain_imm_file(path).spec.
[[nodiscard]] PlainImmSpec load_plain_imm_config(const std::filesystem::path& path);

}  // namespace imm::support
