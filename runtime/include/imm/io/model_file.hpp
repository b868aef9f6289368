// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The model-file schema (SPEC §5, docs/model-schema.md), one module for both sides: the trainer
/// writes through ModelFileWriter, the runtime reads through ModelFileReader.
///
/// A model file is a checked container (container_file.hpp) of format "immtrain-model" whose root
/// attributes are:
///   format = "immtrain-model", schema_version (integer; written: 2, or 3 for a file that needs
///   a version-3 field; read: 1 to 3), model_kind,
///   created_utc, trainer_version, seed, config_toml, dataset_digest, length_unit ("m" | "km",
///   version 2), regime_name, regime_toml, regime_digest (the regime the model was trained for:
///   what it is the frozen answer to; absent in files written before regimes),
///   training.`<metric>` and validation.`<metric>` (reals).
/// Kind-specific content lives in groups named by meaning (e.g. /imm/transition).
///
/// Version 2 files describe themselves: every dataset carries `units` (one unit for every entry,
/// or one per column of a matrix or entry of a vector, comma-separated; "1" is dimensionless) and
/// every matrix `columns` (its column names, comma-separated); a covariance matrix carries
/// `quantity = "covariance"` and the units of its variables (entry (i, j) is in unitᵢ·unitⱼ). Every
/// group with real-valued attributes carries `units` = "name=unit,name=unit,…" naming each of them.
/// Counts are integers and text is variable-length UTF-8. The reader checks all of that on a
/// version-2 file.
///
/// The reader refuses, with a FileError naming the file and the field: a foreign or corrupt
/// file, another format or kind, a schema version newer than kModelSchemaVersion, a missing
/// dataset or attribute, a wrong shape, a version-2 file whose `units` or `columns` are missing
/// or malformed, and values that break the field's rule (NaN/Inf always; σ > 0, w ≥ 0 and
/// probabilities where the schema says so). Version-1 files (no units, no columns on most
/// matrices, fixed-length strings) stay readable.
///
/// Version 3 is version 2 plus fields an older reader would misread if it ignored them: a GA-fuzzy
/// IMM whose tables read normalized innovations (`/ga_fuzzy_imm@antecedents`). A writer that sets
/// such a field calls require_schema_version(3); every other file is still written as version 2,
/// so that the runtimes that read version 2 keep reading it.

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
#include "imm/runtime_export.hpp"
#include "imm/tracking/envelope.hpp"
#include "imm/version.hpp"

namespace imm::io {

/// The container format name of model files.
inline constexpr std::string_view kModelFormat = "immtrain-model";
/// The newest schema version this runtime reads.
inline constexpr int kModelSchemaVersion = imm::kModelSchemaVersion;
/// The version a file is written as unless it needs a newer one (require_schema_version).
inline constexpr int kBaseModelSchemaVersion = imm::kBaseModelSchemaVersion;

/// Where a model came from: the root attributes of SPEC §5.
struct IMM_RUNTIME_EXPORT Provenance {
  /// plain_imm, ga_fuzzy_imm, mlp_input_estimator, wimm, fcm_imm or tsk_sensor.
  std::string model_kind;
  std::string created_utc;        ///< ISO 8601 UTC; the writer fills in "now" when empty
  std::string trainer_version;    ///< git describe of the trainer that wrote the file
  std::int64_t seed = 0;          ///< the training seed (0 for deterministic exports)
  std::string config_toml;        ///< the full config text the model was trained from
  std::string dataset_digest;     ///< SHA-256 of the training data ("" when there is none)
  std::string regime_name;        ///< the regime trained for ("" when none is recorded)
  std::string regime_toml;        ///< its full text
  std::string regime_digest;      ///< SHA-256 of the regime (imm/datasets/regime.hpp)
  std::string length_unit = "m";  ///< unit of every length in the file ("m" | "km"); "" when a
                                  ///< version-1 file does not say
  /// `training.<metric>` root attributes.
  std::map<std::string, double> training_metrics;
  /// `validation.<metric>` root attributes.
  std::map<std::string, double> validation_metrics;
};

/// Whether `unit` is a length unit model files use: "m" or "km".
[[nodiscard]] IMM_RUNTIME_EXPORT bool valid_length_unit(std::string_view unit);

/// The current time as ISO 8601 UTC, e.g. "2026-11-22T00:18:36Z".
[[nodiscard]] IMM_RUNTIME_EXPORT std::string utc_now();

/// Names of the units a model file's values are in, built from its length unit (times in s).
struct IMM_RUNTIME_EXPORT UnitNames {
  /// "m" or "km".
  std::string length = "m";
  /// The unit of a speed.
  [[nodiscard]] std::string speed() const { return length + "/s"; }
  /// The unit of an acceleration.
  [[nodiscard]] std::string acceleration() const { return length + "/s^2"; }
  /// Variance of a position.
  [[nodiscard]] std::string area() const { return length + "^2"; }
  /// Variance of an acceleration (the piecewise-constant white-acceleration noise q).
  [[nodiscard]] std::string acceleration_variance() const { return length + "^2/s^4"; }
  /// Power spectral density of a continuous white acceleration (the continuous-noise q).
  [[nodiscard]] std::string acceleration_density() const { return length + "^2/s^3"; }
};

/// The dimensionless unit.
inline constexpr std::string_view kDimensionless = "1";

/// Writes a model file: the kind's writer fills in the content, commit() adds the provenance and
/// renames the file into place.
class IMM_RUNTIME_EXPORT ModelFileWriter {
 public:
  /// Starts a model file at `path` (written atomically on commit()). Throws FileError when the
  /// kind is empty, the length unit is not "m" or "km", or the folder is missing.
  ModelFileWriter(const std::filesystem::path& path, Provenance provenance);

  /// The units of this file's values.
  [[nodiscard]] const UnitNames& units() const { return units_; }

  /// Writes a matrix dataset with its column names and `units` (one for every entry, or one per
  /// column, comma-separated). Throws FileError when the counts disagree.
  void write_matrix(std::string_view dataset, const Eigen::MatrixXd& matrix,
                    const std::vector<std::string>& columns, std::string_view units);
  /// Writes a covariance matrix of the named variables, whose units are `variable_units` (one per
  /// variable, comma-separated): entry (i, j) is in unitᵢ·unitⱼ.
  void write_covariance(std::string_view dataset, const Eigen::MatrixXd& covariance,
                        const std::vector<std::string>& variables, std::string_view variable_units);
  /// Writes a vector dataset whose entries are in `units` (one for all, or one per entry).
  void write_vector(std::string_view dataset, const Eigen::VectorXd& vector,
                    std::string_view units);
  /// Sets a text or integer attribute. A real attribute needs its units (set_quantity), except on
  /// the root; this throws FileError naming the attribute when one is given here.
  void set_attribute(std::string_view object, std::string_view name, const Attribute& value);
  /// Sets a real attribute and records its units in the object's `units` attribute.
  void set_quantity(std::string_view object, std::string_view name, double value,
                    std::string_view units);

  /// Writes the file as at least `version` (≤ kModelSchemaVersion): for a field an older reader
  /// would misread. Throws FileError for a version this writer does not know.
  void require_schema_version(int version);

  /// The envelope test a tracker of this model runs (imm/tracking/envelope.hpp), written as
  /// `/envelope@{window,significance}`; commit() writes the defaults when this is not called.
  /// Throws FileError naming the field of invalid settings.
  void set_envelope(const EnvelopeSettings& settings);

  /// Writes the provenance, the envelope settings and the groups' `units`, and renames the file
  /// into place.
  void commit();

  /// The container being written (for content outside the schema's helpers).
  [[nodiscard]] ContainerWriter& container() { return container_; }

 private:
  Provenance provenance_;
  UnitNames units_;
  ContainerWriter container_;
  int schema_version_ = kBaseModelSchemaVersion;
  bool envelope_written_ = false;
  /// Per object, "name=unit" of its real attributes, in the order they were set.
  std::map<std::string, std::vector<std::pair<std::string, std::string>>> attribute_units_;
};

/// Reads a model file: a SchemaReader that has also checked the format, the schema version and the
/// kind, and holds the provenance.
class IMM_RUNTIME_EXPORT ModelFileReader : public SchemaReader {
 public:
  /// Opens and validates a model file; `expected_kind` empty accepts any kind.
  explicit ModelFileReader(const std::filesystem::path& path, std::string_view expected_kind = {});

  /// The root attributes.
  [[nodiscard]] const Provenance& provenance() const { return provenance_; }
  /// The file's schema version (1 to kModelSchemaVersion).
  [[nodiscard]] int schema_version() const { return schema_version_; }
  /// The envelope test stored in the file (`/envelope`), or the defaults for a file without one.
  [[nodiscard]] const EnvelopeSettings& envelope() const { return envelope_; }
  /// Schema version ≥ 2: refuses a real attribute of a group that its group's `units` do not name
  /// (a count written as a real, or a quantity without its unit). Every kind's reader calls it
  /// after its own reads, whose refusals name the field more precisely.
  void require_units_of_reals() const;

 private:
  void check_self_description() const;
  void check_values() const;

  Provenance provenance_;
  int schema_version_ = 0;
  EnvelopeSettings envelope_;
};

}  // namespace imm::io
