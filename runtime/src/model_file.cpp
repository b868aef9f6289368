// SPDX-License-Identifier: Apache-2.0
#include "imm/io/model_file.hpp"

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

ModelFileWriter::ModelFileWriter(const std::filesystem::path& path, Provenance provenance)
    : provenance_(std::move(provenance)), container_(path, kModelFormat) {
  if (provenance_.model_kind.empty()) {
    throw FileError(path.string(), "/@model_kind", "model kind must not be empty");
  }
  if (provenance_.created_utc.empty()) provenance_.created_utc = utc_now();
}

void ModelFileWriter::write_matrix(std::string_view dataset, const Eigen::MatrixXd& matrix,
                                   const std::vector<std::string>& columns) {
  container_.write(dataset, matrix);
  if (!columns.empty()) {
    if (static_cast<Eigen::Index>(columns.size()) != matrix.cols()) {
      throw FileError(container_.path().string(), field_path(dataset, "columns"),
                      "names " + std::to_string(columns.size()) + " columns of a matrix with " +
                          std::to_string(matrix.cols()));
    }
    std::string joined;
    for (const auto& column : columns) joined += (joined.empty() ? "" : ",") + column;
    container_.set_attribute(dataset, "columns", joined);
  }
}

void ModelFileWriter::write_vector(std::string_view dataset, const Eigen::VectorXd& vector) {
  container_.write(dataset, Array::from_vector(vector));
}

void ModelFileWriter::set_attribute(std::string_view object, std::string_view name,
                                    const Attribute& value) {
  container_.set_attribute(object, name, value);
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
  if (stated < 1) fail("/@schema_version", "invalid schema version " + std::to_string(stated));
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
}

}  // namespace imm::io
