#include "imm/io/model_file.hpp"

#include <cmath>
#include <ctime>
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
  }
  return "valid";
}

bool satisfies(double value, ValueRule rule) {
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
  }
  return false;
}

}  // namespace

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
    : container_(path, kModelFormat) {
  if (text("/", "format") != kModelFormat) fail("/@format", "is not \"immtrain-model\"");
  const auto version = container_.attribute("/", "schema_version");
  if (!version || !std::holds_alternative<std::int64_t>(*version)) {
    fail("/@schema_version", "missing or not an integer");
  }
  const std::int64_t stated = std::get<std::int64_t>(*version);
  if (stated > kModelSchemaVersion) {
    fail("/@schema_version", "schema version " + std::to_string(stated) +
                                 " is newer than this reader supports (" +
                                 std::to_string(kModelSchemaVersion) +
                                 "); update immtrain to load it");
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
  for (const auto& name : container_.attribute_names("/")) {
    for (auto [prefix, metrics] : {std::pair{std::string_view("training."), &provenance_.training_metrics},
                                   std::pair{std::string_view("validation."), &provenance_.validation_metrics}}) {
      if (name.starts_with(prefix)) {
        (*metrics)[name.substr(prefix.size())] = real("/", name);
      }
    }
  }
}

void ModelFileReader::fail(std::string_view field, const std::string& message) const {
  throw FileError(file(), std::string(field), message);
}

Eigen::MatrixXd ModelFileReader::matrix(std::string_view dataset, int rows, int cols,
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

Eigen::VectorXd ModelFileReader::vector(std::string_view dataset, int size, ValueRule rule) const {
  const std::string field = field_path(dataset);
  if (container_.kind(dataset) == ObjectKind::kDataset && container_.shape(dataset).size() != 1) {
    fail(field, "expected a vector, found rank " + std::to_string(container_.shape(dataset).size()));
  }
  return matrix(dataset, size, 1, rule);
}

double ModelFileReader::real(std::string_view object, std::string_view name, ValueRule rule) const {
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
  return number;
}

std::int64_t ModelFileReader::integer(std::string_view object, std::string_view name,
                                      std::int64_t min, std::int64_t max) const {
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

std::string ModelFileReader::text(std::string_view object, std::string_view name) const {
  const std::string field = field_path(object, name);
  const auto value = container_.attribute(object, name);
  if (!value) fail(field, "missing attribute");
  const auto* string = std::get_if<std::string>(&*value);
  if (string == nullptr) fail(field, "expected text");
  return *string;
}

std::vector<std::string> ModelFileReader::members(std::string_view group) const {
  if (container_.kind(group) != ObjectKind::kGroup) fail(field_path(group), "missing group");
  return container_.children(group);
}

}  // namespace imm::io
