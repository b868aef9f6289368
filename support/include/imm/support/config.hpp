// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Checked reading of TOML configs. Every key a loader reads is recorded; once the loader is done,
/// finish() reports any key that was present but never read ("unknown key", with the key it most
/// likely misspells), so that a typo in a config is an error, not a silently ignored setting. A
/// required key that is missing while a key beside it misspells it reports that unknown key first
/// ("key 'sampel_period': unknown key; did you mean 'sample_period'? (which is missing)"). Type
/// errors name the key; range errors come from the specs' validate() (InvalidParameter) and are
/// re-thrown with the file and key.

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace imm::support {

/// A bad config: names the file and the key ("modes[1].process_noise").
class ConfigError : public std::runtime_error {
 public:
  ConfigError(std::string file, std::string key, const std::string& message);
  [[nodiscard]] const std::string& file() const { return file_; }
  [[nodiscard]] const std::string& key() const { return key_; }

 private:
  std::string file_;
  std::string key_;
};

class ConfigDocument;

/// One TOML table of a document; keys are addressed relative to it.
class ConfigTable {
 public:
  [[nodiscard]] bool has(std::string_view key) const;
  /// Whether the key holds an array.
  [[nodiscard]] bool is_array(std::string_view key) const;
  /// Whether a key that may hold "auto" asks for the default: true when it is absent or "auto";
  /// any other string is an error naming the key (a number or array is read by the caller).
  [[nodiscard]] bool is_auto(std::string_view key) const;
  /// The table's keys, sorted.
  [[nodiscard]] std::vector<std::string> keys() const;

  [[nodiscard]] double real(std::string_view key) const;
  [[nodiscard]] double real_or(std::string_view key, double fallback) const;
  [[nodiscard]] std::int64_t integer(std::string_view key) const;
  [[nodiscard]] std::int64_t integer_or(std::string_view key, std::int64_t fallback) const;
  /// An integer within the range of int (counts, sizes, scan indices): a larger one is an error
  /// naming the key, never a wrapped value.
  [[nodiscard]] int count(std::string_view key) const;
  [[nodiscard]] int count_or(std::string_view key, int fallback) const;
  /// A random seed: a non-negative integer.
  [[nodiscard]] std::uint64_t seed_or(std::string_view key, std::uint64_t fallback) const;
  [[nodiscard]] std::string text(std::string_view key) const;
  [[nodiscard]] std::string text_or(std::string_view key, std::string fallback) const;
  [[nodiscard]] bool boolean_or(std::string_view key, bool fallback) const;
  /// An array of numbers; `size` ≥ 0 requires that many.
  [[nodiscard]] Eigen::VectorXd reals(std::string_view key, long size = -1) const;
  /// An array of equally long arrays of numbers; −1 for any extent.
  [[nodiscard]] Eigen::MatrixXd matrix(std::string_view key, long rows = -1, long cols = -1) const;
  /// An array of strings.
  [[nodiscard]] std::vector<std::string> texts(std::string_view key) const;
  /// A sub-table, or nullopt when absent.
  [[nodiscard]] std::optional<ConfigTable> table(std::string_view key) const;
  /// An array of tables ([[key]]); empty when absent.
  [[nodiscard]] std::vector<ConfigTable> tables(std::string_view key) const;

  /// The full key path of `key` ("modes[1].name").
  [[nodiscard]] std::string path(std::string_view key) const;
  [[noreturn]] void fail(std::string_view key, const std::string& message) const;

 private:
  friend class ConfigDocument;
  ConfigTable(const void* table, std::string prefix,
              std::shared_ptr<const ConfigDocument> document);
  [[nodiscard]] const void* node(std::string_view key) const;

  const void* table_;  // const toml::table*, owned by the document
  std::string prefix_;
  std::shared_ptr<const ConfigDocument> document_;
};

/// A parsed config file.
class ConfigDocument : public std::enable_shared_from_this<ConfigDocument> {
 public:
  /// Parses a file; syntax errors become ConfigError with line and column.
  static std::shared_ptr<ConfigDocument> load(const std::filesystem::path& path);
  /// Parses text (for tests and embedded defaults); `name` stands for the file in errors.
  static std::shared_ptr<ConfigDocument> parse(std::string text, std::string name);
  ~ConfigDocument();

  [[nodiscard]] ConfigTable root() const;
  [[nodiscard]] const std::string& text() const { return text_; }
  [[nodiscard]] const std::string& name() const { return name_; }

  /// Throws ConfigError for the first key that no loader read.
  void finish() const;
  /// Runs `loader`, turning InvalidParameter (a spec's range check) into ConfigError for the key
  /// `prefix` + field, then calls finish().
  template <class Loader>
  auto load_checked(Loader&& loader, const std::string& prefix = "") const -> decltype(loader());

  void mark(std::string key) const { read_keys_.insert(std::move(key)); }
  /// Records a key a loader asked for, present or not (the "did you mean" of an unknown key).
  void ask(std::string key) const { asked_keys_.insert(std::move(key)); }
  /// Of the keys asked for beside `path` (the same table), the one `path` most likely misspells,
  /// or "" when none is close.
  [[nodiscard]] std::string likely_meant(const std::string& path) const;
  /// The keys read so far (full paths).
  [[nodiscard]] const std::set<std::string>& read_keys() const { return read_keys_; }
  [[noreturn]] void rethrow_invalid(const std::string& prefix) const;

 private:
  ConfigDocument() = default;
  struct Parsed;
  std::unique_ptr<Parsed> parsed_;
  std::string text_;
  std::string name_;
  mutable std::set<std::string> read_keys_;
  mutable std::set<std::string> asked_keys_;
};

template <class Loader>
auto ConfigDocument::load_checked(Loader&& loader, const std::string& prefix) const
    -> decltype(loader()) {
  try {
    auto result = loader();
    finish();
    return result;
  } catch (const ConfigError&) {
    throw;
  } catch (const std::invalid_argument&) {
    rethrow_invalid(prefix);
  }
}

}  // namespace imm::support
