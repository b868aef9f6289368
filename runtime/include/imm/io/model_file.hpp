// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The model-file schema (SPEC §5), one module for both sides: the trainer writes through
/// ModelFileWriter, the runtime reads through ModelFileReader.
///
/// A model file is a checked container (container_file.hpp) of format "immtrain-model" whose root
/// attributes are:
///   format = "immtrain-model", schema_version (integer, this reader: 1), model_kind,
///   created_utc, trainer_version, seed, config_toml, dataset_digest,
///   regime_name, regime_toml, regime_digest (the regime the model was trained for: what it is
///   the frozen answer to; absent in files written before regimes),
///   training.<metric> and validation.<metric> (reals).
/// Kind-specific content lives in groups named by meaning (e.g. /imm/transition); a matrix
/// dataset may carry a "columns" attribute naming its columns (comma-separated), which
/// imm-inspect prints as table headers.
///
/// The reader refuses, with a FileError naming the file and the field: a foreign or corrupt
/// file, another format or kind, a schema version newer than kModelSchemaVersion, a missing
/// dataset or attribute, a wrong shape, and values that break the field's rule (NaN/Inf always;
/// σ > 0, w ≥ 0 and probabilities where the schema says so). Older schema versions stay
/// readable: kind readers branch on schema_version().

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "imm/io/container_file.hpp"
#include "imm/io/file_error.hpp"
#include "imm/io/schema_reader.hpp"
#include "imm/version.hpp"

namespace imm::io {

inline constexpr std::string_view kModelFormat = "immtrain-model";
inline constexpr int kModelSchemaVersion = imm::kModelSchemaVersion;

/// Where a model came from: the root attributes of SPEC §5.
struct Provenance {
  std::string model_kind;
  std::string created_utc;      ///< ISO 8601 UTC; the writer fills in "now" when empty
  std::string trainer_version;  ///< git describe of the trainer that wrote the file
  std::int64_t seed = 0;        ///< the training seed (0 for deterministic exports)
  std::string config_toml;      ///< the full config text the model was trained from
  std::string dataset_digest;   ///< SHA-256 of the training data ("" when there is none)
  std::string regime_name;      ///< the regime trained for ("" when none is recorded)
  std::string regime_toml;      ///< its full text
  std::string regime_digest;    ///< SHA-256 of the regime (imm/datasets/regime.hpp)
  std::map<std::string, double> training_metrics;
  std::map<std::string, double> validation_metrics;
};

/// The current time as ISO 8601 UTC, e.g. "2026-11-22T00:18:36Z".
[[nodiscard]] std::string utc_now();

class ModelFileWriter {
 public:
  /// Starts a model file at `path` (written atomically on commit()). Throws FileError when the
  /// kind is empty or the folder is missing.
  ModelFileWriter(const std::filesystem::path& path, Provenance provenance);

  /// Writes a matrix dataset; `columns` (optional) names its columns.
  void write_matrix(std::string_view dataset, const Eigen::MatrixXd& matrix,
                    const std::vector<std::string>& columns = {});
  void write_vector(std::string_view dataset, const Eigen::VectorXd& vector);
  void set_attribute(std::string_view object, std::string_view name, const Attribute& value);

  /// Writes the provenance and renames the file into place.
  void commit();

  [[nodiscard]] ContainerWriter& container() { return container_; }

 private:
  Provenance provenance_;
  ContainerWriter container_;
};

/// Reads a model file: a SchemaReader that has also checked the format, the schema version and the
/// kind, and holds the provenance.
class ModelFileReader : public SchemaReader {
 public:
  /// Opens and validates a model file; `expected_kind` empty accepts any kind.
  explicit ModelFileReader(const std::filesystem::path& path, std::string_view expected_kind = {});

  [[nodiscard]] const Provenance& provenance() const { return provenance_; }
  [[nodiscard]] int schema_version() const { return schema_version_; }

 private:
  Provenance provenance_;
  int schema_version_ = 0;
};

}  // namespace imm::io
