// SPDX-License-Identifier: Apache-2.0
#include "toml_text.hpp"

#include <cstdint>
#include <cstdio>
#include <utility>

namespace imm::support {
namespace {

/// One UTF-8 character at text[i] (a byte above 0x7F): its code point and its length in bytes, or
/// length 0 when the bytes there are not UTF-8 (a stray continuation byte, a truncated or overlong
/// sequence, a surrogate, a code point beyond U+10FFFF).
std::pair<char32_t, std::size_t> utf8_at(const std::string& text, std::size_t i) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned lead = byte(i);
  std::size_t length = 0;
  char32_t code = 0;
  char32_t least = 0;
  if ((lead & 0xE0U) == 0xC0U) {
    length = 2;
    code = lead & 0x1FU;
    least = 0x80;
  } else if ((lead & 0xF0U) == 0xE0U) {
    length = 3;
    code = lead & 0x0FU;
    least = 0x800;
  } else if ((lead & 0xF8U) == 0xF0U) {
    length = 4;
    code = lead & 0x07U;
    least = 0x10000;
  } else {
    return {0, 0};
  }
  if (i + length > text.size()) return {0, 0};
  for (std::size_t k = 1; k < length; ++k) {
    if ((byte(i + k) & 0xC0U) != 0x80U) return {0, 0};
    code = (code << 6U) | (byte(i + k) & 0x3FU);
  }
  if (code < least || code > 0x10FFFF || (code >= 0xD800 && code <= 0xDFFF)) return {0, 0};
  return {code, length};
}

}  // namespace

TomlText toml_text(const std::string& text) {
  enum class State { kCode, kComment, kBasic, kLiteral, kMultiBasic, kMultiLiteral };
  State state = State::kCode;
  TomlText result;
  std::string& out = result.text;
  out.reserve(text.size());
  int depth = 0;           // open [ and { of values (a table header's [ is closed on its line)
  bool line_start = true;  // nothing but blanks yet on this line
  bool rewrite = false;    // the literal string being read is written as a basic string
  std::size_t close = 0;   // where it ends: its closing quotes, or where an unterminated one stops
  const auto fail = [&](std::size_t at, const std::string& what) {
    std::size_t line = 1;
    std::size_t column = 1;
    for (std::size_t k = 0; k < at; ++k) {
      if (text[k] == '\n') {
        ++line;
        column = 1;
      } else if ((static_cast<unsigned char>(text[k]) & 0xC0U) != 0x80U) {
        ++column;
      }
    }
    result.problem =
        "line " + std::to_string(line) + ", column " + std::to_string(column) + ": " + what;
    return result;
  };
  const auto control = [](char c) {
    const auto byte = static_cast<unsigned char>(c);
    return (byte < 0x20 && c != '\t' && c != '\n' && c != '\r') || byte == 0x7F;
  };
  const auto control_problem = [](char c) {
    char code[8];
    std::snprintf(code, sizeof code, "0x%02X", static_cast<unsigned char>(c));
    return std::string("control character ") + code + " (not allowed in TOML)";
  };
  const auto key_start = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '-' || c == '"' ||
           c == '\'' || c == ']';
  };
  const auto starts = [&](std::size_t i, const char* token) {
    return text.compare(i, 3, token) == 0;
  };
  const auto run_of = [&](std::size_t i, char quote) {
    std::size_t n = 0;
    while (i + n < text.size() && text[i + n] == quote) ++n;
    return n;
  };
  const auto has_non_ascii = [&](std::size_t from, std::size_t to) {
    for (std::size_t k = from; k < to; ++k) {
      if (static_cast<unsigned char>(text[k]) >= 0x80) return true;
    }
    return false;
  };
  // A multi-line string's closing quotes: the first run of three or more, whose first one or two
  // belong to the string; more than five is an error (npos), none ends the text.
  const auto multi_close = [&](std::size_t from, char quote) {
    const std::size_t k = text.find(std::string(3, quote), from);
    if (k == std::string::npos) return text.size();
    const std::size_t n = run_of(k, quote);
    return n > 5 ? std::string::npos : k + n - 3;
  };
  const auto escape = [&](char32_t code) {
    char buffer[12];
    if (code <= 0xFFFF) {
      std::snprintf(buffer, sizeof buffer, "\\u%04X", static_cast<unsigned>(code));
    } else {
      std::snprintf(buffer, sizeof buffer, "\\U%08X", static_cast<unsigned>(code));
    }
    out += buffer;
  };
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (control(c)) return fail(i, control_problem(c));
    if (static_cast<unsigned char>(c) >= 0x80) {
      if (state == State::kCode)
        return fail(i, "non-ASCII character outside a string or a comment");
      const auto [code, length] = utf8_at(text, i);
      if (length == 0) return fail(i, "not UTF-8");
      if (state == State::kComment) {
        out += '?';
      } else if ((state == State::kLiteral || state == State::kMultiLiteral) && !rewrite) {
        out.append(text, i, length);
      } else {
        escape(code);
      }
      i += length - 1;
      line_start = false;
      continue;
    }
    const bool was_line_start = line_start;
    line_start = c == '\n' || (line_start && (c == ' ' || c == '\t' || c == '\r'));
    switch (state) {
      case State::kCode:
        if (c == '[' && depth == 0 && was_line_start) {
          std::size_t k = i + 1;
          if (k < text.size() && text[k] == '[') ++k;
          while (k < text.size() && (text[k] == ' ' || text[k] == '\t')) ++k;
          if (k >= text.size() || !key_start(text[k])) {
            return fail(i, "a table header must start with a key");
          }
        }
        if (c == '[' || c == '{') {
          ++depth;
        } else if ((c == ']' || c == '}') && depth > 0) {
          --depth;
        }
        if (c == '#') {
          state = State::kComment;
          out += c;
        } else if (starts(i, "\"\"\"")) {
          state = State::kMultiBasic;
          out += "\"\"\"";
          i += 2;
        } else if (starts(i, "'''")) {
          close = multi_close(i + 3, '\'');
          if (close == std::string::npos) return fail(i, "more than five quotes end this string");
          rewrite = has_non_ascii(i + 3, close);
          state = State::kMultiLiteral;
          out += rewrite ? "\"\"\"" : "'''";
          i += 2;
        } else if (c == '"') {
          state = State::kBasic;
          out += c;
        } else if (c == '\'') {
          close = std::min(text.find_first_of("'\n", i + 1), text.size());
          rewrite = has_non_ascii(i + 1, close);
          state = State::kLiteral;
          out += rewrite ? '"' : '\'';
        } else {
          out += c;
        }
        break;
      case State::kComment:
        if (c == '\n') state = State::kCode;
        out += c;
        break;
      case State::kBasic:
      case State::kMultiBasic:
        if (c == '\\') {
          out += c;
          if (i + 1 < text.size()) {
            const char next = text[i + 1];
            if (control(next)) return fail(i + 1, control_problem(next));
            if (static_cast<unsigned char>(next) >= 0x80) {
              return fail(i, "a backslash before a non-ASCII character (not an escape)");
            }
            out += next;
            line_start = next == '\n';
            ++i;
          }
        } else if (state == State::kBasic && (c == '"' || c == '\n')) {
          state = State::kCode;
          out += c;
        } else if (state == State::kMultiBasic && starts(i, "\"\"\"")) {
          const std::size_t n = run_of(i, '"');
          if (n > 5) return fail(i, "more than five quotes end this string");
          out.append(n, '"');
          i += n - 1;
          state = State::kCode;
        } else {
          out += c;
        }
        break;
      case State::kLiteral:
      case State::kMultiLiteral:
        if (i == close) {
          // The closing quote(s), or the line break ending an unterminated literal string.
          const std::size_t quotes = state == State::kLiteral ? (c == '\'' ? 1 : 0) : 3;
          out.append(quotes, rewrite ? '"' : '\'');
          if (quotes == 0) out += c;
          i += quotes == 3 ? 2 : 0;
          state = State::kCode;
        } else if (rewrite && (c == '\\' || c == '"')) {
          out += '\\';
          out += c;
        } else {
          out += c;
        }
        break;
    }
  }
  return result;
}

}  // namespace imm::support
