// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Thrown when a filter or model description is invalid: names the offending field in the
/// vocabulary of the configs ("modes[1].process_noise"), so that a config loader can point at
/// the key.

#include <stdexcept>
#include <string>
#include <string_view>

#include "imm/runtime_export.hpp"

namespace imm {

/// A parameter outside its valid range, naming the field (e.g. "transition", "process_noise[2]").
class IMM_RUNTIME_EXPORT InvalidParameter : public std::invalid_argument {
 public:
  /// `field`: the parameter's name as the config or model file spells it.
  InvalidParameter(std::string field, std::string message)
      : std::invalid_argument(field + ": " + message),
        field_(std::move(field)),
        message_(std::move(message)) {}

  /// The name of the invalid parameter.
  [[nodiscard]] const std::string& field() const { return field_; }
  /// what() without the leading "field: ".
  [[nodiscard]] const std::string& message() const { return message_; }
  /// The same error for the field as seen from an enclosing description ("filter." + field).
  [[nodiscard]] InvalidParameter within(const std::string& prefix) const {
    return {prefix + field_, message_};
  }

 private:
  std::string field_;
  std::string message_;
};

/// `text` as a message may quote it, whatever a file or a config held: its first 64 bytes, each
/// outside printable ASCII as `\xNN`, so that a hostile name can neither break a message's line
/// nor make it long.
[[nodiscard]] inline std::string printable(std::string_view text) {
  constexpr std::string_view kHex = "0123456789abcdef";
  std::string shown;
  for (const char c : text.substr(0, 64)) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte >= 0x20 && byte < 0x7F) {
      shown.push_back(c);
    } else {
      shown.append("\\x").push_back(kHex[byte >> 4U]);
      shown.push_back(kHex[byte & 0xFU]);
    }
  }
  return shown;
}

/// Throws InvalidParameter(field, message) unless `condition` holds.
inline void require(bool condition, const std::string& field, const std::string& message) {
  if (!condition) throw InvalidParameter(field, message);
}

/// Calls `part.validate()` and names what it refuses under the enclosing description's key
/// `prefix` ("filter." + field): a spec checked as part of a config.
template <class Part>
void validate_within(const std::string& prefix, const Part& part) {
  try {
    part.validate();
  } catch (const InvalidParameter& error) {
    throw error.within(prefix);
  }
}

}  // namespace imm
