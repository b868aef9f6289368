// SPDX-License-Identifier: Apache-2.0
#include "imm/support/measurement_csv.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string_view>

#include "imm/support/csv.hpp"

namespace imm::support {

MeasurementCsv read_measurement_csv(std::istream& in, const std::string& name) {
  MeasurementCsv csv;
  CsvReader reader(in, name);
  CsvLine line;
  bool have_header = false;
  std::string columns[2];
  std::size_t width = 3;  // the header's columns: k or t, the plot's two, any carried along
  while (reader.next(line)) {
    const auto& fields = line.fields;
    if (!have_header) {
      const bool first = fields.size() >= 3 && (fields[0] == "k" || fields[0] == "t");
      if (first && fields[1] == "zx" && fields[2] == "zy") {
        csv.kind = MeasurementKind::kCartesian;
      } else if (first && fields[1] == "range" && fields[2] == "azimuth") {
        csv.kind = MeasurementKind::kPolar;
      } else if (first && fields[1] == "z1" && fields[2] == "z2") {
        csv.model_space = true;
      } else {
        reader.fail(
            "expected the header 'k,zx,zy', 'k,range,azimuth' or 'k,z1,z2' (or 't' for 'k': "
            "times in s), found '" +
            std::string(line.text) + "'");
      }
      for (std::size_t i = 3; i < fields.size(); ++i) {
        if (fields[i].empty()) reader.fail("column " + std::to_string(i + 1) + " has no name");
      }
      width = fields.size();
      csv.timed = fields[0] == "t";
      columns[0] = std::string(fields[1]);
      columns[1] = std::string(fields[2]);
      have_header = true;
      continue;
    }
    MeasurementRow row;
    row.line = line.number;
    if (csv.timed) {
      row.time = parse_real(fields[0], /*finite_only=*/true);
    } else {
      row.scan = parse_integer(fields[0]);
    }
    if (fields.size() != width) {
      row.problem =
          "expected " + std::to_string(width) + " fields, found " + std::to_string(fields.size());
    } else if (csv.timed && !row.time) {
      row.problem = "t '" + std::string(fields[0]) + "' is not a finite number of seconds";
    } else if (!csv.timed && !row.scan) {
      row.problem = "k '" + std::string(fields[0]) + "' is not an integer";
    } else {
      for (int i = 0; i < 2 && row.problem.empty(); ++i) {
        const std::string_view field = fields[static_cast<std::size_t>(i) + 1];
        const std::optional<double> value = parse_real(field, /*finite_only=*/false);
        if (field.empty()) {
          row.problem = "missing " + columns[i];
        } else if (!value) {
          row.problem = columns[i] + " '" + std::string(field) + "' is not a number";
        } else if (!std::isfinite(*value)) {
          row.problem = columns[i] + " is " + std::string(field);
        } else {
          row.z(i) = *value;
        }
      }
    }
    if (!row.problem.empty()) row.z.setConstant(std::numeric_limits<double>::quiet_NaN());
    csv.rows.push_back(std::move(row));
  }
  if (!have_header) throw std::runtime_error(name + ": empty, expected a header line");
  return csv;
}

void scans_from_times(MeasurementCsv& csv, double sample_period, const std::string& name) {
  if (!csv.timed) return;
  std::optional<double> t0;
  for (MeasurementRow& row : csv.rows) {
    if (!row.time) continue;
    if (!t0) t0 = *row.time;
    const double periods = (*row.time - *t0) / sample_period;
    const double whole = std::round(periods);
    if (std::abs(periods - whole) > 1e-6 || std::abs(whole) > 1e15) {
      std::ostringstream message;
      message.precision(10);
      message << name << ':' << row.line << ": column 't': " << *row.time << " s is "
              << *row.time - *t0 << " s after the first plot, not a whole number of the model's "
              << "sample period " << sample_period
              << " s: the plots were recorded at another period than the model was trained for";
      throw std::runtime_error(message.str());
    }
    row.scan = static_cast<std::int64_t>(whole);
  }
}

}  // namespace imm::support
