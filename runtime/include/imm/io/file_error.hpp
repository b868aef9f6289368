// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The error thrown for a bad model or data-set file: it names the file and, where one is to
/// blame, the field (an HDF5 object path, optionally with an attribute: "/imm/transition" or
/// "/\@schema_version").

#include <stdexcept>
#include <string>
#include <string_view>

#include "imm/runtime_export.hpp"

namespace imm::io {

/// The field name of an object ("/a/b") or of one of its attributes ("/a/b@name").
[[nodiscard]] inline std::string field_path(std::string_view object,
                                            std::string_view attribute = {}) {
  std::string field;
  if (object.empty() || object.front() != '/') field.push_back('/');
  field.append(object);
  while (field.size() > 1 && field.back() == '/') field.pop_back();
  if (!attribute.empty()) field.append("@").append(attribute);
  return field;
}

/// A model or data-set file that cannot be read or written, naming the file and the field
/// ("/imm/transition", "/@schema_version").
class IMM_RUNTIME_EXPORT FileError : public std::runtime_error {
 public:
  /// The message reads "<file>: field '<field>': <message>".
  FileError(std::string file, std::string field, const std::string& message)
      : std::runtime_error(compose(file, field, message)),
        file_(std::move(file)),
        field_(std::move(field)) {}

  /// The file.
  [[nodiscard]] const std::string& file() const { return file_; }
  /// The field: an object path, or object\@attribute.
  [[nodiscard]] const std::string& field() const { return field_; }

 private:
  static std::string compose(const std::string& file, const std::string& field,
                             const std::string& message) {
    std::string text = file;
    if (!field.empty()) text += ": field '" + field + "'";
    return text + ": " + message;
  }

  std::string file_;
  std::string field_;
};

}  // namespace imm::io
