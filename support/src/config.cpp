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
#include "imm/support/edit_distance.hpp"
#include "toml_text.hpp"

namespace imm::support {
namespace {

/// The largest config file read: configs are a few KiB; a larger file is not one.
constexpr std::size_t kMaxConfigBytes = std::size_t{4} << 20U;

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

namespace {

// Whether `written` is close enough to `meant` to be its misspelling: a typo or two in a key of
// five characters or more (at most one in three). Shorter keys (q1, q2) are too alike to guess.
bool misspells(std::string_view written, std::string_view meant) {
  if (meant.size() < 5 || written == meant) return false;
  return edit_distance(written, meant) <= std::min<std::size_t>(2, meant.size() / 3);
}

// "modes[1].name" → "modes[1]." (the table), "name" (the key).
std::pair<std::string, std::string> split_path(const std::string& path) {
  const auto dot = path.rfind('.');
  if (dot == std::string::npos) return {"", path};
  return {path.substr(0, dot + 1), path.substr(dot + 1)};
}

}  // namespace

std::string ConfigDocument::likely_meant(const std::string& path) const {
  const auto [table, key] = split_path(path);
  std::string best;
  std::size_t best_distance = 0;
  for (const std::string& asked : asked_keys_) {
    const auto [asked_table, asked_key] = split_path(asked);
    if (asked_table != table || !misspells(key, asked_key)) continue;
    const std::size_t d = edit_distance(key, asked_key);
    if (best.empty() || d < best_distance) {
      best = asked_key;
      best_distance = d;
    }
  }
  return best;
}

void ConfigDocument::finish() const {
  // Depth-first walk; the first unread key is reported.
  std::function<void(const toml::table&, const std::string&)> walk =
      [&](const toml::table& table, const std::string& prefix) {
        for (const auto& [key, node] : table) {
          const std::string path = prefix + std::string(key.str());
          if (read_keys_.count(path) == 0) {
            const std::string meant = likely_meant(path);
            throw ConfigError(
                name_, path,
                meant.empty() ? "unknown key" : "unknown key; did you mean '" + meant + "'?");
          }
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

bool ConfigTable::has(std::string_view key) const {
  document_->ask(path(key));
  return as_table(table_).contains(key);
}

bool ConfigTable::is_array(std::string_view key) const {
  const toml::node* n = as_table(table_).get(key);
  return n != nullptr && n->is_array();
}

bool ConfigTable::is_auto(std::string_view key) const {
  document_->ask(path(key));
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
  document_->ask(path(key));
  const toml::node* n = as_table(table_).get(key);
  if (n == nullptr) {
    // A key beside it that nothing reads and that misspells it is the error to report first.
    for (const auto& [present, value] : as_table(table_)) {
      const std::string written(present.str());
      if (document_->read_keys().count(path(written)) == 0 && misspells(written, key)) {
        fail(written, "unknown key; did you mean '" + std::string(key) + "'? (which is missing)");
      }
    }
    fail(key, "missing");
  }
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
