#pragma once
/// Data-set files: a simulated Monte Carlo set with everything needed to reproduce and audit it.
///
/// A checked container (imm/io/container_file.hpp) of format "immtrain-dataset":
///   /@format, @schema_version (1), @dataset_kind ("maneuver_scenario"), @scenario, @seed,
///   @created_utc, @generator_version, @config_toml, @digest (SHA-256, see digest())
///   /time                  steps
///   /acceleration_input    steps × 2 (ax, ay)
///   /truth                 runs × steps × 4 (x, vx, y, vy)
///   /measurements          runs × steps × 2 (zx, zy or range, azimuth)
///   /parameters            @sample_period, @steps, @runs, @process_noise_sigma,
///                          @measurement_kind, @measurement_sigma_0, @measurement_sigma_1
///   /parameters/initial_state  4 (x, vx, y, vy)
///   /parameters/maneuvers      n × 4 (start, end, ax, ay)
/// The reader recomputes the digest and refuses a file whose data do not match it.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "imm/datasets/maneuver_scenario.hpp"
#include "imm/io/container_file.hpp"
#include "imm/io/schema_reader.hpp"

namespace imm::datasets {

inline constexpr std::string_view kDatasetFormat = "immtrain-dataset";
inline constexpr int kDatasetSchemaVersion = 1;

struct ScenarioDataset {
  ManeuverScenario scenario;
  ScenarioData data;
  std::string digest;
  std::string config_toml;
  std::string created_utc;
  std::string generator_version;
};

/// Writes atomically (temp + rename). Returns the digest written.
std::string write_scenario_dataset(const std::filesystem::path& path,
                                   const ManeuverScenario& scenario, const ScenarioData& data,
                                   const std::string& config_toml,
                                   const std::string& generator_version);

/// Reads and validates; throws imm::io::FileError naming the file and the field.
[[nodiscard]] ScenarioDataset read_scenario_dataset(const std::filesystem::path& path);

// --- Building blocks of every data-set kind (range_sensor_file.hpp uses them too) -----------

/// The root attributes @format, @schema_version, @dataset_kind, @seed, @created_utc,
/// @generator_version, @config_toml and @digest.
void write_dataset_root(io::ContainerWriter& writer, std::string_view kind, std::uint64_t seed,
                        const std::string& config_toml, const std::string& generator_version,
                        const std::string& digest);
/// Refuses a newer schema version or another kind (FileError naming /@schema_version or
/// /@dataset_kind).
void check_dataset_header(const io::SchemaReader& reader, std::string_view kind);
/// Equal-shaped runs (rows × columns each) as one runs × rows × columns array, and back.
[[nodiscard]] io::Array stack_runs(const std::vector<Eigen::MatrixXd>& runs);
[[nodiscard]] std::vector<Eigen::MatrixXd> unstack_runs(const io::Array& array);

}  // namespace imm::datasets
