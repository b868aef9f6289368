// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Data-set files: a split of a regime's tracks with everything needed to reproduce and audit it.
///
/// A checked container (imm/io/container_file.hpp) of format "immtrain-dataset":
///   /@format, @schema_version (2), @dataset_kind ("tracks"), @seed (the split's seed),
///   @created_utc, @generator_version, @config_toml (the regime's text), @digest (SHA-256 of every
///   truth and plot matrix, TrackSet::digest())
///   /truth         tracks × scans × 6 (x, vx, ax, y, vy, ay)
///   /plots         tracks × scans × 2 (zx, zy | range, azimuth | z1, z2)
///   /maneuvering   tracks × scans × 1 (1 where a maneuver acts)
///   /cases         tracks × 4 (case index, the plot noise σ₁, σ₂ and correlation)
///   /parameters    @regime, @regime_digest, @split, @sample_period, @scans, @tracks, @units,
///                  @sensor
///   recorded sets (imm/datasets/recorded.hpp) also:
///   /recordings    tracks × 1 (the recording each window comes from)
///   /parameters    @recorded (1), @has_truth (0: no /truth; every truth value reads as NaN),
///                  @recording_names (each name followed by a newline)
///   and NaN plots (and truth) where a recording has a gap.
/// The reader recomputes the digest and refuses a file whose data do not match it. Schema 1 (the
/// scenario files before regimes) is refused with a message to regenerate.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "imm/datasets/track.hpp"
#include "imm/io/container_file.hpp"
#include "imm/io/schema_reader.hpp"

namespace imm::datasets {

inline constexpr std::string_view kDatasetFormat = "immtrain-dataset";
/// The newest schema this reader reads: 3 adds recorded sets (drawn sets are still written as 2,
/// byte for byte what they were).
inline constexpr int kDatasetSchemaVersion = 3;
inline constexpr int kDrawnDatasetSchemaVersion = 2;

struct TrackSetFile {
  TrackSet set;
  std::string regime_text, regime_digest;
  std::string digest;
  std::string created_utc;
  std::string generator_version;
  std::string units, sensor;  ///< /parameters@units and @sensor
};

/// Writes atomically (temp + rename). Returns the digest written.
std::string write_track_set(const std::filesystem::path& path, const Regime& regime,
                            const TrackSet& set, const std::string& generator_version);

/// Reads and validates; throws imm::io::FileError naming the file and the field.
[[nodiscard]] TrackSetFile read_track_set(const std::filesystem::path& path);

// --- Building blocks of every data-set kind (range_sensor_file.hpp uses them too) -----------

/// The root attributes @format, @schema_version, @dataset_kind, @seed, @created_utc,
/// @generator_version, @config_toml and @digest.
void write_dataset_root(io::ContainerWriter& writer, std::string_view kind, std::uint64_t seed,
                        const std::string& config_toml, const std::string& generator_version,
                        const std::string& digest, int schema_version = kDrawnDatasetSchemaVersion);
/// Refuses a newer schema version or another kind (FileError naming /@schema_version or
/// /@dataset_kind).
void check_dataset_header(const io::SchemaReader& reader, std::string_view kind);
/// Equal-shaped runs (rows × columns each) as one runs × rows × columns array, and back.
[[nodiscard]] io::Array stack_runs(const std::vector<Eigen::MatrixXd>& runs);
[[nodiscard]] std::vector<Eigen::MatrixXd> unstack_runs(const io::Array& array);

}  // namespace imm::datasets
