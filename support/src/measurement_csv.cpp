// SPDX-License-Identifier: Apache-2.0
#include "imm/support/measurement_csv.hpp"

#include <cmath>
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
  while (reader.next(line)) {
    const auto& fields = line.fields;
    if (!have_header) {
      if (fields.size() == 3 && fields[0] == "k" && fields[1] == "zx" && fields[2] == "zy") {
        csv.kind = MeasurementKind::kCartesian;
      } else if (fields.size() == 3 && fields[0] == "k" && fields[1] == "range" &&
                 fields[2] == "azimuth") {
        csv.kind = MeasurementKind::kPolar;
      } else {
        reader.fail("expected the header 'k,zx,zy' or 'k,range,azimuth', found '" +
                    std::string(line.text) + "'");
      }
      columns[0] = std::string(fields[1]);
      columns[1] = std::string(fields[2]);
      have_header = true;
      continue;
    }
    MeasurementRow row;
    row.line = line.number;
    row.scan = parse_integer(fields[0]);
    if (fields.size() != 3) {
      row.problem = "expected 3 fields, found " + std::to_string(fields.size());
    } else if (!row.scan) {
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

}  // namespace imm::support
