// SPDX-License-Identifier: Apache-2.0
#include "imm/io/schema_reader.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace imm::io {
namespace {

const char* rule_text(ValueRule rule) {
  switch (rule) {
    case ValueRule::kFinite:
      return "finite";
    case ValueRule::kPositive:
      return "positive";
    case ValueRule::kNonNegative:
      return "non-negative";
    case ValueRule::kProbability:
      return "a probability in [0, 1]";
    case ValueRule::kFiniteOrMissing:
      return "finite (or NaN where missing)";
  }
  return "valid";
}

bool satisfies(double value, ValueRule rule) {
  if (rule == ValueRule::kFiniteOrMissing) return !std::isinf(value);
  if (!std::isfinite(value)) return false;
  switch (rule) {
    case ValueRule::kFinite:
      return true;
    case ValueRule::kPositive:
      return value > 0.0;
    case ValueRule::kNonNegative:
      return value >= 0.0;
    case ValueRule::kProbability:
      return value >= 0.0 && value <= 1.0;
    case ValueRule::kFiniteOrMissing:
      return true;
  }
  return false;
}

}  // namespace

SchemaReader::SchemaReader(const std::filesystem::path& path, std::string_view format)
    : container_(path, format) {}

Array SchemaReader::array(std::string_view dataset, const std::vector<long>& shape,
                          ValueRule rule) const {
  const std::string field = field_path(dataset);
  if (container_.kind(dataset) != ObjectKind::kDataset) fail(field, "missing dataset");
  // The declared shape is checked against the schema before a single value is read, so a file
  // cannot make the reader allocate for a dataset of the wrong shape.
  const std::vector<std::size_t> declared = container_.shape(dataset);
  bool matches = declared.size() == shape.size();
  for (std::size_t d = 0; matches && d < shape.size(); ++d) {
    matches = shape[d] < 0 || declared[d] == static_cast<std::size_t>(shape[d]);
  }
  if (!matches) {
    auto text = [](const auto& extents) {
      std::string out;
      for (const auto& e : extents) {
        if (!out.empty()) out += "x";
        out += (static_cast<long>(e) < 0) ? std::string("any") : std::to_string(e);
      }
      return out;
    };
    fail(field, "expected shape " + text(shape) + ", found " + text(declared));
  }
  Array values = container_.read(dataset);
  for (std::size_t i = 0; i < values.values.size(); ++i) {
    if (!satisfies(values.values[i], rule)) {
      std::ostringstream message;
      message << "value at flat index " << i << " = " << values.values[i] << " is not "
              << rule_text(rule);
      fail(field, message.str());
    }
  }
  return values;
}

void SchemaReader::fail(std::string_view field, const std::string& message) const {
  throw FileError(file(), std::string(field), message);
}

void SchemaReader::fail_spec(std::string_view group, const InvalidParameter& error,
                             std::initializer_list<std::string_view> datasets) const {
  const std::string& f = error.field();
  const bool dataset = std::any_of(datasets.begin(), datasets.end(), [&](std::string_view name) {
    return f.rfind(name, 0) == 0 && (f.size() == name.size() || f[name.size()] == '[');
  });
  fail(std::string(group) + (dataset ? "/" : "@") + f, error.what());
}

Eigen::MatrixXd SchemaReader::matrix(std::string_view dataset, int rows, int cols,
                                     ValueRule rule) const {
  const std::string field = field_path(dataset);
  if (container_.kind(dataset) != ObjectKind::kDataset) fail(field, "missing dataset");
  const Array array = container_.read(dataset);
  Eigen::Index actual_rows = 0, actual_cols = 0;
  if (array.rank() == 1) {
    actual_rows = static_cast<Eigen::Index>(array.shape[0]);
    actual_cols = 1;
  } else if (array.rank() == 2) {
    actual_rows = static_cast<Eigen::Index>(array.shape[0]);
    actual_cols = static_cast<Eigen::Index>(array.shape[1]);
  } else {
    fail(field, "expected a matrix, found rank " + std::to_string(array.rank()));
  }
  if ((rows >= 0 && actual_rows != rows) || (cols >= 0 && actual_cols != cols)) {
    std::ostringstream message;
    message << "expected shape " << (rows >= 0 ? std::to_string(rows) : "any") << "x"
            << (cols >= 0 ? std::to_string(cols) : "any") << ", found " << actual_rows << "x"
            << actual_cols;
    fail(field, message.str());
  }
  for (std::size_t i = 0; i < array.values.size(); ++i) {
    if (!satisfies(array.values[i], rule)) {
      const auto cols_count = static_cast<std::size_t>(actual_cols);
      std::ostringstream message;
      message << "entry (" << i / cols_count << ", " << i % cols_count << ") = " << array.values[i]
              << " is not " << rule_text(rule);
      fail(field, message.str());
    }
  }
  return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      array.values.data(), actual_rows, actual_cols);
}

Eigen::VectorXd SchemaReader::vector(std::string_view dataset, int size, ValueRule rule) const {
  const std::string field = field_path(dataset);
  if (container_.kind(dataset) == ObjectKind::kDataset && container_.shape(dataset).size() != 1) {
    fail(field,
         "expected a vector, found rank " + std::to_string(container_.shape(dataset).size()));
  }
  return matrix(dataset, size, 1, rule);
}

double SchemaReader::real(std::string_view object, std::string_view name, ValueRule rule) const {
  const std::string field = field_path(object, name);
  const auto value = container_.attribute(object, name);
  if (!value) fail(field, "missing attribute");
  double number = 0.0;
  if (const auto* d = std::get_if<double>(&*value)) {
    number = *d;
  } else if (const auto* i = std::get_if<std::int64_t>(&*value)) {
    number = static_cast<double>(*i);
  } else {
    fail(field, "expected a number, found text");
  }
  if (!satisfies(number, rule)) {
    std::ostringstream message;
    message << "value " << number << " is not " << rule_text(rule);
    fail(field, message.str());
  }
  if (require_attribute_units_ && field_path(object) != "/") {
    const auto units = container_.attribute(object, "units");
    const std::string* list = units ? std::get_if<std::string>(&*units) : nullptr;
    const std::string entry = std::string(name) + "=";
    if (list == nullptr || ("," + *list).find("," + entry) == std::string::npos) {
      fail(field_path(object, "units"), "does not give the units of '" + std::string(name) + "'");
    }
  }
  return number;
}

std::int64_t SchemaReader::integer(std::string_view object, std::string_view name, std::int64_t min,
                                   std::int64_t max) const {
  const std::string field = field_path(object, name);
  const auto value = container_.attribute(object, name);
  if (!value) fail(field, "missing attribute");
  const auto* number = std::get_if<std::int64_t>(&*value);
  if (number == nullptr) fail(field, "expected an integer");
  if (*number < min || *number > max) {
    fail(field, "value " + std::to_string(*number) + " outside [" + std::to_string(min) + ", " +
                    std::to_string(max) + "]");
  }
  return *number;
}

std::string SchemaReader::text(std::string_view object, std::string_view name) const {
  const std::string field = field_path(object, name);
  const auto value = container_.attribute(object, name);
  if (!value) fail(field, "missing attribute");
  const auto* string = std::get_if<std::string>(&*value);
  if (string == nullptr) fail(field, "expected text");
  return *string;
}

std::vector<std::string> SchemaReader::members(std::string_view group) const {
  if (container_.kind(group) != ObjectKind::kGroup) fail(field_path(group), "missing group");
  return container_.children(group);
}

}  // namespace imm::io
