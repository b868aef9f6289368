// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Sensor-sample files of seed 002 (format "immtrain-dataset", as dataset_file.hpp), kind
/// "range_sensor": a range sensor's calibration data — what a TSK model of it is fitted on.
///   /positions  samples × 2 (xi, eta), true obstacle positions
///   /outputs    samples × 2 (z1, z2), the sensor's outputs
///   /parameters @regime, @regime_digest, @noise_sigma;  /parameters/box 2 × 2 (lower; upper)
/// Root: @format, @schema_version, @dataset_kind, @seed, @created_utc, @generator_version,
/// @config_toml (the regime's text), @digest (SHA-256 of the arrays; the reader recomputes it).

#include <filesystem>
#include <string>

#include "imm/datasets/range_sensor.hpp"
#include "imm/datasets/regime.hpp"

namespace imm::datasets {

/// SHA-256 of positions and outputs.
[[nodiscard]] std::string digest(const RangeSensorData& data);

/// Writes the calibration samples of a regime's range sensor (drawn with `seed`).
std::string write_range_sensor_dataset(const std::filesystem::path& path, const Regime& regime,
                                       const RangeSensorData& data, std::uint64_t seed,
                                       const std::string& generator_version);

struct RangeSensorDataset {
  RangeSensorData data;
  std::string regime, regime_digest;
  std::string digest;
};
/// Reads and validates (shapes, finite values, the digest); FileError names the field.
[[nodiscard]] RangeSensorDataset read_range_sensor_dataset(const std::filesystem::path& path);

/// Sensor samples from a file: a "range_sensor" data set (.h5, digest checked) or a CSV with the
/// header xi,eta,z1,z2 (true position, sensor output; '#' lines are comments). FileError names
/// the file and, for a CSV, the line.
[[nodiscard]] RangeSensorData read_sensor_samples(const std::filesystem::path& path);

}  // namespace imm::datasets
