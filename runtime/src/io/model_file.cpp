// SPDX-License-Identifier: Apache-2.0
#include "imm/io/model_file.hpp"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <tuple>

#include "imm/core/invalid_parameter.hpp"

namespace imm::io {

std::string utc_now() {
  const std::time_t now = std::time(nullptr);
  std::tm parts{};
  gmtime_r(&now, &parts);
  char buffer[32];
  std::strftime(buffer, sizeof buffer, "%Y-%m-%dT%H:%M:%SZ", &parts);
  return buffer;
}

// --- Writer ----------------------------------------------------------------------------------

namespace {

std::vector<std::string> split_list(std::string_view text) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    parts.emplace_back(text.substr(start, comma == std::string_view::npos ? comma : comma - start));
    if (comma == std::string_view::npos) return parts;
    start = comma + 1;
  }
}

std::string join_list(const std::vector<std::string>& parts) {
  std::string joined;
  for (const auto& part : parts) {
    if (!joined.empty()) joined.push_back(',');
    joined.append(part);
  }
  return joined;
}

// A column, variable or attribute name: 1 to 64 of [A-Za-z0-9_.-] (printable, no list syntax).
bool valid_name(std::string_view part) {
  if (part.empty() || part.size() > 64) return false;
  return std::all_of(part.begin(), part.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '.' || c == '-';
  });
}

// A unit as docs/model-schema.md states them: "1", or FACTOR, or (FACTOR | "1") "/" FACTOR, where
// FACTOR is m, km, s or rad with an optional exponent ^2 … ^9 (m/s^2, m^2/s^4, km^2/s^3, 1/s).
bool valid_unit(std::string_view unit) {
  auto factor = [](std::string_view f) {
    const auto caret = f.find('^');
    const std::string_view base = f.substr(0, caret);
    if (base != "m" && base != "km" && base != "s" && base != "rad") return false;
    if (caret == std::string_view::npos) return true;
    const std::string_view exponent = f.substr(caret + 1);
    return exponent.size() == 1 && exponent[0] >= '2' && exponent[0] <= '9';
  };
  if (unit == "1") return true;
  const auto slash = unit.find('/');
  if (slash == std::string_view::npos) return factor(unit);
  const std::string_view numerator = unit.substr(0, slash);
  return (numerator == "1" || factor(numerator)) && factor(unit.substr(slash + 1));
}

// Why a dataset's `units` do not fit its `entries` columns (a matrix) or entries (a vector): one
// unit for all, or one valid unit each. Empty when they fit. The writer and the reader share it.
std::string units_problem(const std::vector<std::string>& units, std::size_t entries,
                          std::string_view what) {
  if (units.size() != 1 && units.size() != entries) {
    return "gives " + std::to_string(units.size()) + " units for " + std::to_string(entries) + " " +
           std::string(what);
  }
  for (const auto& unit : units) {
    if (!valid_unit(unit)) {
      return "invalid unit '" + printable(unit) + "' (docs/model-schema.md: units)";
    }
  }
  return {};
}

std::string length_unit_problem(const std::string& unit) {
  return valid_length_unit(unit) ? std::string()
                                 : "must be \"m\" or \"km\", got \"" + printable(unit) + "\"";
}

}  // namespace

bool valid_length_unit(std::string_view unit) { return unit == "m" || unit == "km"; }

ModelFileWriter::ModelFileWriter(const std::filesystem::path& path, Provenance provenance)
    : provenance_(std::move(provenance)), container_(path, kModelFormat) {
  if (provenance_.model_kind.empty()) {
    throw FileError(path.string(), "/@model_kind", "model kind must not be empty");
  }
  if (const auto problem = length_unit_problem(provenance_.length_unit); !problem.empty()) {
    throw FileError(path.string(), "/@length_unit", problem);
  }
  units_.length = provenance_.length_unit;
  if (provenance_.created_utc.empty()) provenance_.created_utc = utc_now();
}

void ModelFileWriter::write_matrix(std::string_view dataset, const Eigen::MatrixXd& matrix,
                                   const std::vector<std::string>& columns,
                                   std::string_view units) {
  const std::string file = container_.path().string();
  if (static_cast<Eigen::Index>(columns.size()) != matrix.cols()) {
    throw FileError(file, field_path(dataset, "columns"),
                    "names " + std::to_string(columns.size()) + " columns of a matrix with " +
                        std::to_string(matrix.cols()));
  }
  for (const auto& column : columns) {
    if (!valid_name(column)) {
      throw FileError(file, field_path(dataset, "columns"),
                      "invalid column name '" + printable(column) + "'");
    }
  }
  if (const auto problem = units_problem(split_list(units), columns.size(), "columns");
      !problem.empty()) {
    throw FileError(file, field_path(dataset, "units"), problem);
  }
  container_.write(dataset, matrix);
  container_.set_attribute(dataset, "columns", join_list(columns));
  container_.set_attribute(dataset, "units", std::string(units));
}

void ModelFileWriter::write_covariance(std::string_view dataset, const Eigen::MatrixXd& covariance,
                                       const std::vector<std::string>& variables,
                                       std::string_view variable_units) {
  if (split_list(variable_units).size() != variables.size()) {
    throw FileError(container_.path().string(), field_path(dataset, "units"),
                    "a covariance needs one unit per variable");
  }
  write_matrix(dataset, covariance, variables, variable_units);
  container_.set_attribute(dataset, "quantity", std::string("covariance"));
}

void ModelFileWriter::write_vector(std::string_view dataset, const Eigen::VectorXd& vector,
                                   std::string_view units) {
  if (const auto problem =
          units_problem(split_list(units), static_cast<std::size_t>(vector.size()), "entries");
      !problem.empty()) {
    throw FileError(container_.path().string(), field_path(dataset, "units"), problem);
  }
  container_.write(dataset, Array::from_vector(vector));
  container_.set_attribute(dataset, "units", std::string(units));
}

void ModelFileWriter::set_attribute(std::string_view object, std::string_view name,
                                    const Attribute& value) {
  if (std::holds_alternative<double>(value) && field_path(object) != "/") {
    throw FileError(container_.path().string(), field_path(object, name),
                    "a real attribute needs its units (set_quantity)");
  }
  container_.set_attribute(object, name, value);
}

void ModelFileWriter::set_quantity(std::string_view object, std::string_view name, double value,
                                   std::string_view units) {
  if (!valid_name(name) || !valid_unit(units)) {
    throw FileError(container_.path().string(), field_path(object, name),
                    "invalid name or unit '" + printable(units) + "'");
  }
  container_.set_attribute(object, name, value);
  auto& list = attribute_units_[field_path(object)];
  std::erase_if(list, [&](const auto& entry) { return entry.first == name; });
  list.emplace_back(name, units);
}

void ModelFileWriter::require_schema_version(int version) {
  if (version < kBaseModelSchemaVersion || version > kModelSchemaVersion) {
    throw FileError(container_.path().string(), "/@schema_version",
                    "cannot write schema version " + std::to_string(version));
  }
  schema_version_ = std::max(schema_version_, version);
}

void ModelFileWriter::set_envelope(const EnvelopeSettings& settings) {
  try {
    settings.validate();
  } catch (const InvalidParameter& invalid) {
    throw FileError(container_.path().string(), "/envelope", invalid.what());
  }
  container_.create_group("/envelope");
  set_attribute("/envelope", "window", std::int64_t{settings.window});
  set_quantity("/envelope", "significance", settings.significance, kDimensionless);
  set_quantity("/envelope", "scale", settings.scale, kDimensionless);
  set_quantity("/envelope", "dof", settings.dof, kDimensionless);
  envelope_written_ = true;
}

void ModelFileWriter::commit() {
  if (!envelope_written_) set_envelope(EnvelopeSettings{});
  container_.set_attribute("/", "format", std::string(kModelFormat));
  container_.set_attribute("/", "schema_version", std::int64_t{schema_version_});
  container_.set_attribute("/", "model_kind", provenance_.model_kind);
  container_.set_attribute("/", "created_utc", provenance_.created_utc);
  container_.set_attribute("/", "trainer_version", provenance_.trainer_version);
  container_.set_attribute("/", "seed", provenance_.seed);
  container_.set_attribute("/", "config_toml", provenance_.config_toml);
  container_.set_attribute("/", "dataset_digest", provenance_.dataset_digest);
  container_.set_attribute("/", "length_unit", provenance_.length_unit);
  for (const auto& [object, list] : attribute_units_) {
    std::vector<std::string> entries;
    entries.reserve(list.size());
    for (const auto& [name, unit] : list)
      entries.push_back(std::string(name).append("=").append(unit));
    container_.set_attribute(object, "units", join_list(entries));
  }
  if (!provenance_.regime_name.empty()) {
    container_.set_attribute("/", "regime_name", provenance_.regime_name);
    container_.set_attribute("/", "regime_toml", provenance_.regime_toml);
    container_.set_attribute("/", "regime_digest", provenance_.regime_digest);
  }
  for (const auto& [name, value] : provenance_.training_metrics) {
    container_.set_attribute("/", "training." + name, value);
  }
  for (const auto& [name, value] : provenance_.validation_metrics) {
    container_.set_attribute("/", "validation." + name, value);
  }
  container_.commit();
}

// --- Reader ----------------------------------------------------------------------------------

ModelFileReader::ModelFileReader(const std::filesystem::path& path, std::string_view expected_kind)
    : SchemaReader(path, kModelFormat) {
  if (text("/", "format") != kModelFormat) fail("/@format", "is not \"immtrain-model\"");
  const auto version = container().attribute("/", "schema_version");
  if (!version || !std::holds_alternative<std::int64_t>(*version)) {
    fail("/@schema_version", "missing or not an integer");
  }
  const std::int64_t stated = std::get<std::int64_t>(*version);
  if (stated > kModelSchemaVersion) {
    fail("/@schema_version",
         "schema version " + std::to_string(stated) + " is newer than this reader supports (" +
             std::to_string(kModelSchemaVersion) + "); update immtrain to load it");
  }
  if (stated < kOldestModelSchemaVersion) {
    fail("/@schema_version", "invalid schema version " + std::to_string(stated));
  }
  schema_version_ = static_cast<int>(stated);

  provenance_.model_kind = text("/", "model_kind");
  if (!expected_kind.empty() && provenance_.model_kind != expected_kind) {
    fail("/@model_kind", "holds a '" + printable(provenance_.model_kind) + "' model, expected '" +
                             std::string(expected_kind) + "'");
  }
  provenance_.created_utc = text("/", "created_utc");
  provenance_.trainer_version = text("/", "trainer_version");
  provenance_.seed = integer("/", "seed", 0, INT64_MAX);
  provenance_.config_toml = text("/", "config_toml");
  provenance_.dataset_digest = text("/", "dataset_digest");
  if (schema_version_ >= 2) {
    provenance_.length_unit = text("/", "length_unit");
    if (const auto problem = length_unit_problem(provenance_.length_unit); !problem.empty()) {
      fail("/@length_unit", problem);
    }
  } else {
    provenance_.length_unit.clear();
  }
  if (container().attribute("/", "regime_name")) {
    provenance_.regime_name = text("/", "regime_name");
    provenance_.regime_toml = text("/", "regime_toml");
    provenance_.regime_digest = text("/", "regime_digest");
  }
  for (const auto& name : container().attribute_names("/")) {
    for (auto [prefix, metrics] :
         {std::pair{std::string_view("training."), &provenance_.training_metrics},
          std::pair{std::string_view("validation."), &provenance_.validation_metrics}}) {
      if (name.starts_with(prefix)) {
        (*metrics)[name.substr(prefix.size())] = real("/", name);
      }
    }
  }
  // Texts are text: the one-line ones hold no control byte, the TOML texts none but tab and line
  // breaks (a newline or an ESC would reach every message and table that shows them).
  for (const auto& [field, value, lines] :
       {std::tuple{"/@model_kind", &provenance_.model_kind, false},
        std::tuple{"/@created_utc", &provenance_.created_utc, false},
        std::tuple{"/@trainer_version", &provenance_.trainer_version, false},
        std::tuple{"/@dataset_digest", &provenance_.dataset_digest, false},
        std::tuple{"/@regime_name", &provenance_.regime_name, false},
        std::tuple{"/@regime_digest", &provenance_.regime_digest, false},
        std::tuple{"/@config_toml", &provenance_.config_toml, true},
        std::tuple{"/@regime_toml", &provenance_.regime_toml, true}}) {
    const auto bad = std::find_if(value->begin(), value->end(), [lines = lines](char c) {
      const auto u = static_cast<unsigned char>(c);
      if (lines && (c == '\t' || c == '\n' || c == '\r')) return false;
      return u < 0x20 || u == 0x7f;
    });
    if (bad != value->end()) {
      fail(field, "holds the control character \\x" +
                      std::string(1, "0123456789abcdef"[static_cast<unsigned char>(*bad) >> 4U]) +
                      std::string(1, "0123456789abcdef"[static_cast<unsigned char>(*bad) & 0xfU]) +
                      " at byte " + std::to_string(bad - value->begin()));
    }
  }
  check_values();
  if (schema_version_ >= 2) {
    check_self_description();
    require_attribute_units();
  }
  if (container().kind("/envelope") != ObjectKind::kMissing) {
    envelope_.window =
        static_cast<int>(integer("/envelope", "window", 1, EnvelopeSettings::kMaxWindow));
    envelope_.significance = real("/envelope", "significance", ValueRule::kProbability);
    envelope_.scale = real("/envelope", "scale", ValueRule::kPositive);
    envelope_.dof = real("/envelope", "dof", ValueRule::kNonNegative);
    try {
      envelope_.validate();
    } catch (const InvalidParameter& invalid) {
      fail("/envelope@" + invalid.field().substr(invalid.field().find('.') + 1), invalid.what());
    }
  }
}

void ModelFileReader::check_values() const {
  // One rule for every number in the file, whether a loader reads it or not (training curves,
  // the GA levels' metadata): a real is finite, an integer is a count or a version (≥ 0).
  for (const auto& object : container().objects()) {
    for (const auto& name : container().attribute_names(object)) {
      const auto value = container().attribute(object, name);
      if (const auto* real = value ? std::get_if<double>(&*value) : nullptr) {
        if (!std::isfinite(*real)) {
          fail(field_path(object, name), "value " + std::to_string(*real) + " is not finite");
        }
      } else if (const auto* integer = value ? std::get_if<std::int64_t>(&*value) : nullptr) {
        if (*integer < 0) {
          fail(field_path(object, name), "negative (" + std::to_string(*integer) + ")");
        }
      }
    }
    if (container().kind(object) == ObjectKind::kDataset) {
      const Array array = container().read(object);
      for (std::size_t i = 0; i < array.values.size(); ++i) {
        if (std::isfinite(array.values[i])) continue;
        const std::string entry = array.rank() == 2
                                      ? "(" + std::to_string(i / array.shape[1]) + ", " +
                                            std::to_string(i % array.shape[1]) + ")"
                                      : std::to_string(i);
        fail(field_path(object),
             "entry " + entry + " = " + std::to_string(array.values[i]) + " is not finite");
      }
    }
  }
}

void ModelFileReader::check_self_description() const {
  for (const auto& object : container().objects()) {
    const auto attributes = container().attribute_names(object);
    const auto has = [&](std::string_view name) {
      return std::find(attributes.begin(), attributes.end(), name) != attributes.end();
    };
    if (container().kind(object) == ObjectKind::kDataset) {
      const auto shape = container().shape(object);
      if (!has("units")) fail(field_path(object, "units"), "missing (schema version 2)");
      const auto units = split_list(text(object, "units"));
      std::string problem;
      if (shape.size() == 2) {
        if (!has("columns")) fail(field_path(object, "columns"), "missing (schema version 2)");
        const auto columns = split_list(text(object, "columns"));
        for (const auto& column : columns) {
          if (!valid_name(column)) {
            fail(field_path(object, "columns"),
                 "column name '" + printable(column) + "' is not 1 to 64 of [A-Za-z0-9_.-]");
          }
        }
        if (columns.size() != shape[1]) {
          fail(field_path(object, "columns"), "names " + std::to_string(columns.size()) +
                                                  " columns of a matrix with " +
                                                  std::to_string(shape[1]));
        }
        problem = units_problem(units, columns.size(), "columns");
      } else {
        problem = units_problem(units, shape.size() == 1 ? shape[0] : 1, "entries");
      }
      if (!problem.empty()) fail(field_path(object, "units"), problem);
      continue;
    }
    if (object == "/") continue;  // the root's reals are the training metrics (SPEC §5)
    if (has("units")) {           // the entries' names are checked as real() reads them
      for (const auto& entry : split_list(text(object, "units"))) {
        const std::size_t equals = entry.find('=');
        if (equals == std::string::npos || !valid_name(entry.substr(0, equals)) ||
            !valid_unit(entry.substr(equals + 1))) {
          fail(field_path(object, "units"), "entry '" + printable(entry) + "' is not name=unit");
        }
      }
    }
  }
}

void ModelFileReader::require_units_of_reals() const {
  if (schema_version_ < 2) return;
  // Every real attribute of a group has its unit (and so a meaning), whether a loader reads it or
  // not: a count written as a real (2.5 generations) is refused here, after the kind's reader has
  // refused what it reads with its own, more precise words.
  for (const auto& object : container().objects()) {
    if (object == "/" || container().kind(object) == ObjectKind::kDataset) continue;
    const auto attributes = container().attribute_names(object);
    const bool has_units =
        std::find(attributes.begin(), attributes.end(), "units") != attributes.end();
    const auto units_list = has_units ? "," + text(object, "units") : std::string();
    for (const auto& name : attributes) {
      const auto value = container().attribute(object, name);
      if (value && std::holds_alternative<double>(*value) &&
          units_list.find("," + name + "=") == std::string::npos) {
        fail(field_path(object, "units"), "does not give the units of the real '" + name +
                                              "' (a count is an integer; a quantity has a unit)");
      }
    }
  }
}

}  // namespace imm::io
