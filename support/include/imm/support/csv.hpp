// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The one CSV reader of every CSV input (measurements for imm-track, published rule tables for
/// `imm-train import-rules`, sensor samples for `imm-train tsk --data`, the benchmark workloads'
/// tables): lines split at commas with the surrounding spaces and a trailing '\r' removed, blank
/// lines and '#' comments skipped ("#@ key = value" directive lines returned when asked), and
/// strict numbers: the whole field is the number — "1.0oops", "1 2", "", "0x10" and "1e" are not
/// numbers, "+2" and "-3.5e-2" are; NaN and infinities are refused where the reader says so.

#include <cstdint>
#include <istream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace imm::support {

[[nodiscard]] std::string_view trim(std::string_view text);
/// The comma-separated fields of a line, each trimmed.
[[nodiscard]] std::vector<std::string_view> split_csv(std::string_view line);
/// The field as a number, or nothing (see above). `finite_only` also refuses nan and inf.
[[nodiscard]] std::optional<double> parse_real(std::string_view field, bool finite_only = true);
[[nodiscard]] std::optional<std::int64_t> parse_integer(std::string_view field);

struct CsvLine {
  std::size_t number = 0;                ///< 1-based line number in the file
  std::string_view text;                 ///< the trimmed line
  std::vector<std::string_view> fields;  ///< its trimmed fields (empty for a directive)
  bool directive = false;                ///< "#@ key = value": key in fields[0]… see directive()
  std::string_view key, value;           ///< a directive's key and value, trimmed
};

class CsvReader {
 public:
  /// `directives`: return "#@ key = value" lines (CsvLine::directive) instead of skipping them.
  CsvReader(std::istream& in, std::string name, bool directives = false);

  /// The next line that is not blank or a comment; false at the end. The views of `line` stay
  /// valid until the next call.
  bool next(CsvLine& line);

  [[nodiscard]] const std::string& name() const { return name_; }
  /// "name:line", the line last returned.
  [[nodiscard]] std::string where() const;
  /// Throws std::runtime_error("name:line: message").
  [[noreturn]] void fail(const std::string& message) const;
  /// Field `i` of `line` as a finite number, or fail() naming the column and the text.
  [[nodiscard]] double real(const CsvLine& line, std::size_t i, std::string_view column) const;

  /// A longer line is refused (fail()) before it is read whole.
  static constexpr std::size_t kMaxLineBytes = std::size_t{1} << 20;

 private:
  bool read_line();

  std::istream& in_;
  std::string name_;
  bool directives_ = false;
  std::string buffer_;
  std::size_t number_ = 0;
};

}  // namespace imm::support
