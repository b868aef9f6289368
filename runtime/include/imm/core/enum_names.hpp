// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// One name table per enum: each value with the one name configs, model files and reports spell
/// it with. to_string() and the parsers of every enum read their table, so that a new value is
/// named in one place and every error lists the valid names.

#include <array>
#include <cstddef>
#include <string>
#include <string_view>

#include "imm/core/invalid_parameter.hpp"

namespace imm {

/// An enum value and its name.
template <class Enum>
struct EnumName {
  /// The value.
  Enum value;
  /// Its one name ("cv", "piecewise", …).
  std::string_view name;
};

/// The name of `value` in `names`; "?" for a value the table lacks.
template <class Enum, std::size_t N>
[[nodiscard]] constexpr std::string_view name_of(const std::array<EnumName<Enum>, N>& names,
                                                 Enum value) {
  for (const auto& entry : names) {
    if (entry.value == value) return entry.name;
  }
  return "?";
}

/// The names of a table as a sentence: "cv, ca or singer".
template <class Enum, std::size_t N>
[[nodiscard]] std::string names_listed(const std::array<EnumName<Enum>, N>& names) {
  std::string text;
  for (std::size_t i = 0; i < N; ++i) {
    if (i > 0) text += i + 1 == N ? " or " : ", ";
    text += names[i].name;
  }
  return text;
}

/// The value named `name`; otherwise InvalidParameter(field, "unknown <what> '<name>' (expected
/// <the names>)"), the name as printable() shows it.
template <class Enum, std::size_t N>
[[nodiscard]] Enum value_named(const std::array<EnumName<Enum>, N>& names, std::string_view name,
                               const std::string& field, std::string_view what) {
  for (const auto& entry : names) {
    if (entry.name == name) return entry.value;
  }
  throw InvalidParameter(field, "unknown " + std::string(what) + " '" + printable(name) +
                                    "' (expected " + names_listed(names) + ")");
}

}  // namespace imm
