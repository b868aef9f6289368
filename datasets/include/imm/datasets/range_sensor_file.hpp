#pragma once
/// Data-set files of seed 002 (format "immtrain-dataset", as dataset_file.hpp):
///
/// dataset_kind "range_sensor": the sensor data a TSK model is fitted on
///   /positions  samples × 2 (xi, eta), true obstacle positions
///   /outputs    samples × 2 (z1, z2), the distorted, noisy sensor outputs
///   /parameters @knee, @softness, @noise_sigma, @samples;  /parameters/box 2 × 2 (lower; upper)
/// dataset_kind "cut_in": one row of the vehicle cut-in experiment
///   /truth         steps × 6 (xi, vxi, axi, eta, veta, aeta)
///   /measurements  runs × steps × 2 (z1, z2)
///   /parameters    @sample_period, @steps, @runs, @knee, @softness, @r_sigma_xi, @r_sigma_eta
/// Root: @format, @schema_version, @dataset_kind, @seed, @created_utc, @generator_version,
/// @config_toml, @digest (SHA-256 of the arrays; the reader recomputes it).

#include <filesystem>
#include <string>

#include "imm/datasets/range_sensor.hpp"

namespace imm::datasets {

/// SHA-256 of positions and outputs.
[[nodiscard]] std::string digest(const RangeSensorData& data);
[[nodiscard]] std::string digest(const CutInData& data);

std::string write_range_sensor_dataset(const std::filesystem::path& path,
                                       const RangeSensorDataConfig& config,
                                       const RangeSensorData& data, const std::string& config_toml,
                                       const std::string& generator_version);

struct RangeSensorDataset {
  RangeSensorData data;
  RangeDistortion distortion;
  double noise_sigma = 0.0;
  std::string digest;
};
/// Reads and validates (shapes, finite values, the digest); FileError names the field.
[[nodiscard]] RangeSensorDataset read_range_sensor_dataset(const std::filesystem::path& path);

std::string write_cut_in_dataset(const std::filesystem::path& path, const CutInScenario& scenario,
                                 const CutInData& data, const std::string& config_toml,
                                 const std::string& generator_version);

struct CutInDataset {
  CutInData data;
  double sample_period = 0.0;
  RangeDistortion distortion;
  Eigen::Vector2d r_sigma = Eigen::Vector2d::Zero();  ///< √R₁₁, √R₂₂
  std::string digest;
};
/// Reads and validates (shapes, finite values, the digest); FileError names the field.
[[nodiscard]] CutInDataset read_cut_in_dataset(const std::filesystem::path& path);

}  // namespace imm::datasets
