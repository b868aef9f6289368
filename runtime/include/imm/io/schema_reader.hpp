// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Validated access to a container's content: every getter checks presence, type, shape and a value
/// rule, and throws a FileError naming the file and the field. Model files and data-set files read
/// through it.

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/io/container_file.hpp"
#include "imm/io/file_error.hpp"
#include "imm/runtime_export.hpp"

namespace imm::io {

/// Rule a numeric field must satisfy on read.
enum class ValueRule {
  kFinite,           ///< any finite value
  kPositive,         ///< > 0 (σ, sample periods, variances that must not vanish)
  kNonNegative,      ///< ≥ 0 (rule weights w, process-noise variances)
  kProbability,      ///< in [0, 1]
  kFiniteOrMissing,  ///< finite, or NaN for a missing value (a recording's gaps); never ±∞
};

/// Validated, field-naming access to a container's content (see the file comment).
class IMM_RUNTIME_EXPORT SchemaReader {
 public:
  /// Opens and verifies a container of `format` (see ContainerReader).
  SchemaReader(const std::filesystem::path& path, std::string_view format);

  /// The verified container.
  [[nodiscard]] const ContainerReader& container() const { return container_; }
  /// The file's path, for messages.
  [[nodiscard]] std::string file() const { return container_.path().string(); }

  /// An N-d array whose shape matches `shape` (−1: any extent) and whose values obey `rule`.
  [[nodiscard]] Array array(std::string_view dataset, const std::vector<long>& shape,
                            ValueRule rule = ValueRule::kFinite) const;
  /// A rows×cols matrix (−1: any extent). A 1-D dataset reads as a column.
  [[nodiscard]] Eigen::MatrixXd matrix(std::string_view dataset, int rows, int cols,
                                       ValueRule rule = ValueRule::kFinite) const;
  /// A 1-D dataset of `size` entries (−1: any).
  [[nodiscard]] Eigen::VectorXd vector(std::string_view dataset, int size,
                                       ValueRule rule = ValueRule::kFinite) const;
  /// A scalar number attribute (an integer reads as a real) that obeys `rule`.
  [[nodiscard]] double real(std::string_view object, std::string_view name,
                            ValueRule rule = ValueRule::kFinite) const;
  /// An integer attribute within [min, max].
  [[nodiscard]] std::int64_t integer(std::string_view object, std::string_view name,
                                     std::int64_t min, std::int64_t max) const;
  /// A text attribute.
  [[nodiscard]] std::string text(std::string_view object, std::string_view name) const;
  /// The names of a group's members, sorted; throws when the group is missing.
  [[nodiscard]] std::vector<std::string> members(std::string_view group) const;

  /// Throws FileError for `field` of this file.
  [[noreturn]] void fail(std::string_view field, const std::string& message) const;
  /// Throws FileError for a spec's InvalidParameter raised when validating what was read from
  /// `group`: the field is the group's dataset when the spec's field is one of `datasets` (or an
  /// entry of one: "process_noise[2]" → `<group>`/process_noise[2]), else the group's attribute
  /// (`<group>`\@`<field>`).
  [[noreturn]] void fail_spec(std::string_view group, const InvalidParameter& error,
                              std::initializer_list<std::string_view> datasets) const;

 protected:
  /// From here on, real() requires the units of every real attribute it reads outside the root
  /// in its object's `units` attribute (model-file schema version 2).
  void require_attribute_units() { require_attribute_units_ = true; }

 private:
  bool require_attribute_units_ = false;
  ContainerReader container_;
};

}  // namespace imm::io
