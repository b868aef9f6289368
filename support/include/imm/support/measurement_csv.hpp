// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Measurement CSV files for imm-track: a header line `k,zx,zy` (Cartesian) or `k,range,azimuth`
/// (polar, azimuth in radians from the y axis) or `k,z1,z2` (plots in the model's own measurement
/// space: a range sensor's outputs, as imm-data writes them), then one row per scan; or the same
/// with a time column `t` (seconds) instead of the scan index `k`, which the reader turns into
/// scans with the model's sample period (scans_from_times). Named columns after those three are
/// carried along unread (the truth x, vx, y, vy of `imm-data export`), every row then holding as
/// many fields as the header. Lines starting with '#' and blank lines are skipped. A row that
/// cannot be used is not dropped silently: it comes back with its line number and a problem text,
/// and with its scan index when that was readable.

#include <Eigen/Core>
#include <cstdint>
#include <istream>
#include <optional>
#include <string>
#include <vector>

#include "imm/filters/plain_imm.hpp"

namespace imm::support {

struct MeasurementRow {
  std::size_t line = 0;              ///< 1-based line number in the file
  std::optional<std::int64_t> scan;  ///< the k column, when readable (scans_from_times for t)
  std::optional<double> time;        ///< the t column, when the file has one and it is readable
  Eigen::Vector2d z = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  std::string problem;  ///< empty for a good row
};

struct MeasurementCsv {
  MeasurementKind kind = MeasurementKind::kCartesian;
  bool timed = false;        ///< the first column is t (s), not k
  bool model_space = false;  ///< z1, z2: in whatever space the model's plots are (`kind` unused)
  std::vector<MeasurementRow> rows;
};

/// Parses the stream. A missing or unknown header is a std::runtime_error naming the file and
/// line; bad rows are returned with their problem.
[[nodiscard]] MeasurementCsv read_measurement_csv(std::istream& in, const std::string& name);

/// For a file with a t column: each readable row's scan k = (t − t₀)/T, t₀ the first readable time.
/// Throws std::runtime_error naming the file, the line and the column 't' when a time is not a
/// whole number of sample periods after t₀ (within 10⁻⁶ T): the file was recorded at another
/// period than the model's.
void scans_from_times(MeasurementCsv& csv, double sample_period, const std::string& name);

}  // namespace imm::support
