// SPDX-License-Identifier: Apache-2.0
#pragma once
// A config's text made safe for toml++ before it parses it (config.cpp). Not installed.

#include <string>

namespace imm::support {

/// The text toml++ parses, or what is wrong with the config's text.
struct TomlText {
  std::string text;
  std::string problem;  ///< "line L, column C: …"; empty when `text` can be parsed
};

/// What TOML forbids and toml++ 3.3 does not survive is refused here, with its line and column: a
/// raw control character other than tab, LF and CR anywhere (toml++ asserts on a NUL inside a key),
/// a table header whose first character cannot start a key ("[", "[ =", "[[#": toml++ asserts),
/// bytes that are not UTF-8, and a non-ASCII character outside strings and comments (never valid
/// there). And toml++ never sees a byte above 0x7F: its Unicode whitespace test reaches an
/// unreachable branch for U+00A1…U+0499 wherever it looks at a character outside a string — in a
/// bare value's look-ahead ("x = 1.'é'"), after the line-ending backslash of a valid multi-line
/// string — so a string's non-ASCII character is written as its \u or \U escape (a literal string
/// holding one becomes the basic string of the same characters) and a comment's as '?'. A valid
/// document parses to the same values; only toml++'s columns after such a character on its line
/// count the escape's characters.
[[nodiscard]] TomlText toml_text(const std::string& text);

}  // namespace imm::support
