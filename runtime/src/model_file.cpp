// SPDX-License-Identifier: Apache-2.0
#include "imm/io/model_file.hpp"

#include <algorithm>
#include <ctime>

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

bool valid_name(std::string_view part) {
  return !part.empty() && part.find_first_of(",=") == std::string_view::npos;
}

}  // namespace

ModelFileWriter::ModelFileWriter(const std::filesystem::path& path, Provenance provenance)
    : provenance_(std::move(provenance)), container_(path, kModelFormat) {
  if (provenance_.model_kind.empty()) {
    throw FileError(path.string(), "/@model_kind", "model kind must not be empty");
  }
  if (provenance_.length_unit != "m" && provenance_.length_unit != "km") {
    throw FileError(path.string(), "/@length_unit",
                    "must be \"m\" or \"km\", got \"" + provenance_.length_unit + "\"");
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
      throw FileError(file, field_path(dataset, "columns"), "invalid column name '" + column + "'");
    }
  }
  const auto unit_list = split_list(units);
  if (unit_list.size() != 1 && unit_list.size() != columns.size()) {
    throw FileError(file, field_path(dataset, "units"),
                    "gives " + std::to_string(unit_list.size()) + " units for " +
                        std::to_string(columns.size()) + " columns");
  }
  for (const auto& unit : unit_list) {
    if (!valid_name(unit)) {
      throw FileError(file, field_path(dataset, "units"), "invalid unit '" + unit + "'");
    }
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
  const auto unit_list = split_list(units);
  if (unit_list.size() != 1 && static_cast<Eigen::Index>(unit_list.size()) != vector.size()) {
    throw FileError(container_.path().string(), field_path(dataset, "units"),
                    "gives " + std::to_string(unit_list.size()) + " units for " +
                        std::to_string(vector.size()) + " entries");
  }
  for (const auto& unit : unit_list) {
    if (!valid_name(unit)) {
      throw FileError(container_.path().string(), field_path(dataset, "units"),
                      "invalid unit '" + unit + "'");
    }
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
  if (!valid_name(name) || !valid_name(units)) {
    throw FileError(container_.path().string(), field_path(object, name),
                    "invalid name or unit '" + std::string(units) + "'");
  }
  container_.set_attribute(object, name, value);
  auto& list = attribute_units_[field_path(object)];
  std::erase_if(list, [&](const auto& entry) { return entry.first == name; });
  list.emplace_back(name, units);
}

void ModelFileWriter::commit() {
  container_.set_attribute("/", "format", std::string(kModelFormat));
  container_.set_attribute("/", "schema_version", std::int64_t{kModelSchemaVersion});
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
    fail("/@model_kind", "holds a '" + provenance_.model_kind + "' model, expected '" +
                             std::string(expected_kind) + "'");
  }
  provenance_.created_utc = text("/", "created_utc");
  provenance_.trainer_version = text("/", "trainer_version");
  provenance_.seed = integer("/", "seed", 0, INT64_MAX);
  provenance_.config_toml = text("/", "config_toml");
  provenance_.dataset_digest = text("/", "dataset_digest");
  if (schema_version_ >= 2) {
    provenance_.length_unit = text("/", "length_unit");
    if (provenance_.length_unit != "m" && provenance_.length_unit != "km") {
      fail("/@length_unit", "must be \"m\" or \"km\", got \"" + provenance_.length_unit + "\"");
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
  if (schema_version_ >= 2) {
    check_self_description();
    require_attribute_units();
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
      for (const auto& unit : units) {
        if (!valid_name(unit)) fail(field_path(object, "units"), "invalid unit '" + unit + "'");
      }
      if (shape.size() == 2) {
        if (!has("columns")) fail(field_path(object, "columns"), "missing (schema version 2)");
        const auto columns = split_list(text(object, "columns"));
        if (columns.size() != shape[1]) {
          fail(field_path(object, "columns"), "names " + std::to_string(columns.size()) +
                                                  " columns of a matrix with " +
                                                  std::to_string(shape[1]));
        }
        if (units.size() != 1 && units.size() != columns.size()) {
          fail(field_path(object, "units"), "gives " + std::to_string(units.size()) +
                                                " units for " + std::to_string(columns.size()) +
                                                " columns");
        }
      } else if (units.size() != 1 && (shape.size() != 1 || units.size() != shape[0])) {
        fail(field_path(object, "units"),
             "gives " + std::to_string(units.size()) + " units, expected one or one per entry");
      }
      continue;
    }
    if (object == "/") continue;  // the root's reals are the training metrics (SPEC §5)
    if (has("units")) {           // the entries' names are checked as real() reads them
      for (const auto& entry : split_list(text(object, "units"))) {
        const std::size_t equals = entry.find('=');
        if (equals == std::string::npos || !valid_name(entry.substr(0, equals)) ||
            !valid_name(entry.substr(equals + 1))) {
          fail(field_path(object, "units"), "entry '" + entry + "' is not name=unit");
        }
      }
    }
  }
}

}  // namespace imm::io
