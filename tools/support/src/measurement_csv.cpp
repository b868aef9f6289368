#include "imm/support/measurement_csv.hpp"

#include <charconv>
#include <cmath>
#include <stdexcept>
#include <string_view>

namespace imm::support {
namespace {

std::string_view trim(std::string_view text) {
  const auto first = text.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(" \t\r");
  return text.substr(first, last - first + 1);
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    fields.push_back(trim(line.substr(start, comma - start)));
    if (comma == std::string_view::npos) return fields;
    start = comma + 1;
  }
}

template <class T>
bool parse_number(std::string_view text, T& value) {
  if (text.empty()) return false;
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  return error == std::errc() && end == text.data() + text.size();
}

}  // namespace

MeasurementCsv read_measurement_csv(std::istream& in, const std::string& name) {
  MeasurementCsv csv;
  std::string line_text;
  std::size_t line = 0;
  bool have_header = false;
  std::string columns[2];
  while (std::getline(in, line_text)) {
    ++line;
    const std::string_view text = trim(line_text);
    if (text.empty() || text.front() == '#') continue;
    const auto fields = split(text);
    if (!have_header) {
      if (fields.size() == 3 && fields[0] == "k" && fields[1] == "zx" && fields[2] == "zy") {
        csv.kind = MeasurementKind::kCartesian;
      } else if (fields.size() == 3 && fields[0] == "k" && fields[1] == "range" &&
                 fields[2] == "azimuth") {
        csv.kind = MeasurementKind::kPolar;
      } else {
        throw std::runtime_error(name + ":" + std::to_string(line) +
                                 ": expected the header 'k,zx,zy' or 'k,range,azimuth', found '" +
                                 std::string(text) + "'");
      }
      columns[0] = std::string(fields[1]);
      columns[1] = std::string(fields[2]);
      have_header = true;
      continue;
    }
    MeasurementRow row;
    row.line = line;
    std::int64_t scan = 0;
    if (!fields.empty() && parse_number(fields[0], scan)) row.scan = scan;
    if (fields.size() != 3) {
      row.problem = "expected 3 fields, found " + std::to_string(fields.size());
    } else if (!row.scan) {
      row.problem = "k '" + std::string(fields[0]) + "' is not an integer";
    } else {
      for (int i = 0; i < 2 && row.problem.empty(); ++i) {
        double value = 0.0;
        const std::string_view field = fields[static_cast<std::size_t>(i) + 1];
        if (field.empty()) {
          row.problem = "missing " + columns[i];
        } else if (!parse_number(field, value)) {
          row.problem = columns[i] + " '" + std::string(field) + "' is not a number";
        } else if (!std::isfinite(value)) {
          row.problem = columns[i] + " is " + std::string(field);
        } else {
          row.z(i) = value;
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
