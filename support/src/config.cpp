// SPDX-License-Identifier: Apache-2.0
#include "imm/support/config.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <utility>

#include "imm/core/invalid_parameter.hpp"

namespace imm::support {
namespace {

/// The largest config file read: configs are a few KiB; a larger file is not one.
constexpr std::size_t kMaxConfigBytes = std::size_t{4} << 20U;

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

const toml::table& as_table(const void* table) { return *static_cast<const toml::table*>(table); }

std::string type_name(const toml::node& node) {
  switch (node.type()) {
    case toml::node_type::string:
      return "a string";
    case toml::node_type::integer:
      return "an integer";
    case toml::node_type::floating_point:
      return "a number";
    case toml::node_type::boolean:
      return "a boolean";
    case toml::node_type::array:
      return "an array";
    case toml::node_type::table:
      return "a table";
    default:
      return "a date or time";
  }
}

std::optional<double> number_of(const toml::node& node) {
  if (const auto* f = node.as_floating_point()) return f->get();
  if (const auto* i = node.as_integer()) return static_cast<double>(i->get());
  return std::nullopt;
}

}  // namespace

ConfigError::ConfigError(std::string file, std::string key, const std::string& message)
    : std::runtime_error(file + (key.empty() ? "" : ": key '" + key + "'") + ": " + message),
      file_(std::move(file)),
      key_(std::move(key)) {}

struct ConfigDocument::Parsed {
  toml::table table;
};

ConfigDocument::~ConfigDocument() = default;

std::shared_ptr<ConfigDocument> ConfigDocument::parse(std::string text, std::string name) {
  std::shared_ptr<ConfigDocument> document(new ConfigDocument());
  document->text_ = std::move(text);
  document->name_ = std::move(name);
  if (document->text_.size() > kMaxConfigBytes) {
    throw ConfigError(document->name_, "",
                      "larger than " + std::to_string(kMaxConfigBytes >> 20U) + " MiB");
  }
  const TomlText toml_input = toml_text(document->text_);
  if (!toml_input.problem.empty()) throw ConfigError(document->name_, "", toml_input.problem);
  try {
    document->parsed_ = std::make_unique<Parsed>(
        Parsed{toml::parse(toml_input.text, std::string_view(document->name_))});
  } catch (const toml::parse_error& error) {
    std::ostringstream message;
    message << "line " << error.source().begin.line << ", column " << error.source().begin.column
            << ": ";
    // One line: toml++ quotes the offending character, which may be a line break.
    for (const char c : error.description()) {
      if (c == '\n') {
        message << "\\n";
      } else if (c == '\r') {
        message << "\\r";
      } else if (c == '\t') {
        message << "\\t";
      } else {
        message << c;
      }
    }
    throw ConfigError(document->name_, "", message.str());
  }
  return document;
}

std::shared_ptr<ConfigDocument> ConfigDocument::load(const std::filesystem::path& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) {
    throw ConfigError(path.string(), "", "no such config file");
  }
  if (const auto bytes = std::filesystem::file_size(path, error);
      !error && bytes > kMaxConfigBytes) {
    throw ConfigError(path.string(), "",
                      "larger than " + std::to_string(kMaxConfigBytes >> 20U) + " MiB");
  }
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  if (!in.good() && !in.eof()) throw ConfigError(path.string(), "", "cannot read");
  return parse(buffer.str(), path.string());
}

ConfigTable ConfigDocument::root() const { return {&parsed_->table, "", shared_from_this()}; }

void ConfigDocument::finish() const {
  // Depth-first walk; the first unread key is reported.
  std::function<void(const toml::table&, const std::string&)> walk =
      [&](const toml::table& table, const std::string& prefix) {
        for (const auto& [key, node] : table) {
          const std::string path = prefix + std::string(key.str());
          if (read_keys_.count(path) == 0) throw ConfigError(name_, path, "unknown key");
          if (const auto* sub = node.as_table()) {
            walk(*sub, path + ".");
          } else if (const auto* array = node.as_array();
                     array != nullptr && !array->empty() && array->is_array_of_tables()) {
            for (std::size_t i = 0; i < array->size(); ++i) {
              walk(*array->at(i).as_table(), path + "[" + std::to_string(i) + "].");
            }
          }
        }
      };
  walk(parsed_->table, "");
}

void ConfigDocument::rethrow_invalid(const std::string& prefix) const {
  try {
    throw;
  } catch (const InvalidParameter& error) {
    throw ConfigError(name_, prefix + error.field(), error.message());
  } catch (const std::invalid_argument& error) {
    throw ConfigError(name_, prefix.empty() ? "" : prefix.substr(0, prefix.size() - 1),
                      error.what());
  }
}

ConfigTable::ConfigTable(const void* table, std::string prefix,
                         std::shared_ptr<const ConfigDocument> document)
    : table_(table), prefix_(std::move(prefix)), document_(std::move(document)) {}

std::string ConfigTable::path(std::string_view key) const { return prefix_ + std::string(key); }

void ConfigTable::fail(std::string_view key, const std::string& message) const {
  throw ConfigError(document_->name(), path(key), message);
}

bool ConfigTable::has(std::string_view key) const { return as_table(table_).contains(key); }

bool ConfigTable::is_array(std::string_view key) const {
  const toml::node* n = as_table(table_).get(key);
  return n != nullptr && n->is_array();
}

bool ConfigTable::is_auto(std::string_view key) const {
  const toml::node* n = as_table(table_).get(key);
  if (n == nullptr) return true;
  if (const auto* text = n->as_string()) {
    document_->mark(path(key));
    if (text->get() != "auto")
      fail(key, "expected \"auto\" or a value, found '" + text->get() + "'");
    return true;
  }
  return false;
}

std::vector<std::string> ConfigTable::keys() const {
  std::vector<std::string> names;
  for (const auto& [key, node] : as_table(table_)) names.emplace_back(key.str());
  return names;
}

const void* ConfigTable::node(std::string_view key) const {
  const toml::node* n = as_table(table_).get(key);
  if (n == nullptr) fail(key, "missing");
  document_->mark(path(key));
  return n;
}

double ConfigTable::real(std::string_view key) const {
  const auto& n = *static_cast<const toml::node*>(node(key));
  const auto value = number_of(n);
  if (!value) fail(key, "expected a number, found " + type_name(n));
  if (!std::isfinite(*value)) fail(key, "must be finite");
  return *value;
}

double ConfigTable::real_or(std::string_view key, double fallback) const {
  return has(key) ? real(key) : fallback;
}

std::int64_t ConfigTable::integer(std::string_view key) const {
  const auto& n = *static_cast<const toml::node*>(node(key));
  const auto* value = n.as_integer();
  if (value == nullptr) fail(key, "expected an integer, found " + type_name(n));
  return value->get();
}

std::int64_t ConfigTable::integer_or(std::string_view key, std::int64_t fallback) const {
  return has(key) ? integer(key) : fallback;
}

int ConfigTable::count(std::string_view key) const {
  const std::int64_t value = integer(key);
  if (value < std::numeric_limits<int>::min() || value > std::numeric_limits<int>::max()) {
    fail(key, "integer " + std::to_string(value) + " is out of range");
  }
  return static_cast<int>(value);
}

int ConfigTable::count_or(std::string_view key, int fallback) const {
  return has(key) ? count(key) : fallback;
}

std::uint64_t ConfigTable::seed_or(std::string_view key, std::uint64_t fallback) const {
  if (!has(key)) return fallback;
  const std::int64_t seed = integer(key);
  if (seed < 0) fail(key, "must be non-negative");
  return static_cast<std::uint64_t>(seed);
}

std::string ConfigTable::text(std::string_view key) const {
  const auto& n = *static_cast<const toml::node*>(node(key));
  const auto* value = n.as_string();
  if (value == nullptr) fail(key, "expected a string, found " + type_name(n));
  return value->get();
}

std::string ConfigTable::text_or(std::string_view key, std::string fallback) const {
  return has(key) ? text(key) : std::move(fallback);
}

bool ConfigTable::boolean_or(std::string_view key, bool fallback) const {
  if (!has(key)) return fallback;
  const auto& n = *static_cast<const toml::node*>(node(key));
  const auto* value = n.as_boolean();
  if (value == nullptr) fail(key, "expected true or false, found " + type_name(n));
  return value->get();
}

Eigen::VectorXd ConfigTable::reals(std::string_view key, long size) const {
  const auto& n = *static_cast<const toml::node*>(node(key));
  const auto* array = n.as_array();
  if (array == nullptr) fail(key, "expected an array of numbers, found " + type_name(n));
  if (size >= 0 && static_cast<long>(array->size()) != size) {
    fail(key,
         "expected " + std::to_string(size) + " numbers, found " + std::to_string(array->size()));
  }
  Eigen::VectorXd values(static_cast<Eigen::Index>(array->size()));
  for (std::size_t i = 0; i < array->size(); ++i) {
    const auto value = number_of(array->at(i));
    if (!value) fail(key, "entry " + std::to_string(i) + " is " + type_name(array->at(i)));
    if (!std::isfinite(*value)) fail(key, "entry " + std::to_string(i) + " must be finite");
    values(static_cast<Eigen::Index>(i)) = *value;
  }
  return values;
}

Eigen::MatrixXd ConfigTable::matrix(std::string_view key, long rows, long cols) const {
  const auto& n = *static_cast<const toml::node*>(node(key));
  const auto* array = n.as_array();
  if (array == nullptr) fail(key, "expected an array of rows, found " + type_name(n));
  const auto row_count = static_cast<long>(array->size());
  if ((rows >= 0 && row_count != rows) || row_count == 0) {
    fail(key, "expected " + (rows >= 0 ? std::to_string(rows) : std::string("some")) +
                  " rows, found " + std::to_string(row_count));
  }
  Eigen::MatrixXd values;
  for (long i = 0; i < row_count; ++i) {
    const auto* row = array->at(static_cast<std::size_t>(i)).as_array();
    if (row == nullptr) fail(key, "row " + std::to_string(i) + " is not an array");
    const auto width = static_cast<long>(row->size());
    if (i == 0) {
      if ((cols >= 0 && width != cols) || width == 0) {
        fail(key, "expected " + (cols >= 0 ? std::to_string(cols) : std::string("some")) +
                      " columns, found " + std::to_string(width));
      }
      values.resize(row_count, width);
    } else if (width != values.cols()) {
      fail(key, "row " + std::to_string(i) + " has " + std::to_string(width) +
                    " entries, row 0 has " + std::to_string(values.cols()));
    }
    for (long j = 0; j < width; ++j) {
      const auto value = number_of(row->at(static_cast<std::size_t>(j)));
      if (!value || !std::isfinite(*value)) {
        fail(key,
             "entry (" + std::to_string(i) + ", " + std::to_string(j) + ") is not a finite number");
      }
      values(i, j) = *value;
    }
  }
  return values;
}

std::vector<std::string> ConfigTable::texts(std::string_view key) const {
  const auto& n = *static_cast<const toml::node*>(node(key));
  const auto* array = n.as_array();
  if (array == nullptr) fail(key, "expected an array of strings, found " + type_name(n));
  std::vector<std::string> values;
  for (std::size_t i = 0; i < array->size(); ++i) {
    const auto* s = array->at(i).as_string();
    if (s == nullptr) fail(key, "entry " + std::to_string(i) + " is not a string");
    values.push_back(s->get());
  }
  return values;
}

std::optional<ConfigTable> ConfigTable::table(std::string_view key) const {
  if (!has(key)) return std::nullopt;
  const auto& n = *static_cast<const toml::node*>(node(key));
  const auto* sub = n.as_table();
  if (sub == nullptr) fail(key, "expected a table, found " + type_name(n));
  return ConfigTable(sub, path(key) + ".", document_);
}

std::vector<ConfigTable> ConfigTable::tables(std::string_view key) const {
  std::vector<ConfigTable> result;
  if (!has(key)) return result;
  const auto& n = *static_cast<const toml::node*>(node(key));
  const auto* array = n.as_array();
  if (array == nullptr || (!array->empty() && !array->is_array_of_tables())) {
    fail(key, "expected an array of tables ([[" + std::string(key) + "]]), found " + type_name(n));
  }
  for (std::size_t i = 0; i < array->size(); ++i) {
    result.emplace_back(ConfigTable(array->at(i).as_table(),
                                    path(key) + "[" + std::to_string(i) + "].", document_));
  }
  return result;
}

}  // namespace imm::support
