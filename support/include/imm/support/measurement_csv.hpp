// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Measurement CSV files for imm-track: a header line `k,zx,zy` (Cartesian) or `k,range,azimuth`
/// (polar, azimuth in radians from the y axis), then one row per scan. Lines starting with '#'
/// and blank lines are skipped. A row that cannot be used is not dropped silently: it comes back
/// with its line number and a problem text, and with its scan index when that was readable.

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
  std::optional<std::int64_t> scan;  ///< the k column, when readable
  Eigen::Vector2d z = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  std::string problem;  ///< empty for a good row
};

struct MeasurementCsv {
  MeasurementKind kind = MeasurementKind::kCartesian;
  std::vector<MeasurementRow> rows;
};

/// Parses the stream. A missing or unknown header is a std::runtime_error naming the file and
/// line; bad rows are returned with their problem.
[[nodiscard]] MeasurementCsv read_measurement_csv(std::istream& in, const std::string& name);

}  // namespace imm::support
