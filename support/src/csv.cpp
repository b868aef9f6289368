// SPDX-License-Identifier: Apache-2.0
#include "imm/support/csv.hpp"

#include <charconv>
#include <cmath>
#include <stdexcept>

namespace imm::support {

std::string_view trim(std::string_view text) {
  const auto first = text.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(" \t\r");
  return text.substr(first, last - first + 1);
}

std::vector<std::string_view> split_csv(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    fields.push_back(trim(line.substr(start, comma - start)));
    if (comma == std::string_view::npos) return fields;
    start = comma + 1;
  }
}

namespace {

constexpr std::string_view kUtf8ByteOrderMark = "\xEF\xBB\xBF";

template <class T>
std::optional<T> parse_whole(std::string_view text) {
  text = trim(text);
  if (text.size() > 1 && text.front() == '+' && text[1] != '-' && text[1] != '+') {
    text.remove_prefix(1);  // from_chars takes no '+'
  }
  if (text.empty()) return std::nullopt;
  T value{};
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return value;
}

}  // namespace

std::optional<double> parse_real(std::string_view field, bool finite_only) {
  const std::optional<double> value = parse_whole<double>(field);
  if (value && finite_only && !std::isfinite(*value)) return std::nullopt;
  return value;
}

std::optional<std::int64_t> parse_integer(std::string_view field) {
  return parse_whole<std::int64_t>(field);
}

CsvReader::CsvReader(std::istream& in, std::string name, bool directives)
    : in_(in), name_(std::move(name)), directives_(directives) {}

bool CsvReader::read_line() {
  // std::getline would grow the buffer to whatever a line holds (a hostile file's 2 GB line);
  // chunks of at most kMaxLineBytes are read instead.
  buffer_.clear();
  char chunk[4096];
  for (;;) {
    in_.getline(chunk, sizeof chunk);
    const auto got = static_cast<std::size_t>(in_.gcount());
    const bool full = in_.fail() && !in_.eof() && got == sizeof chunk - 1;
    // Stored characters: all of a full chunk, all at the end of the file, else all but the
    // newline that getline counted (a NUL byte is kept and then refused as a field's text).
    const std::size_t stored = full || in_.eof() ? got : got - 1;
    buffer_.append(chunk, stored);
    if (buffer_.size() > kMaxLineBytes) {
      ++number_;
      fail("the line is longer than " + std::to_string(kMaxLineBytes) + " bytes");
    }
    if (full) {
      in_.clear();  // the line goes on
      continue;
    }
    if (in_.eof() && got == 0 && buffer_.empty()) return false;  // the end
    if (in_.bad()) fail("read error");
    in_.clear(in_.rdstate() & std::ios::eofbit);
    // A UTF-8 byte order mark, which spreadsheets write at the start of a "CSV UTF-8" file, is
    // not part of the first field.
    if (number_ == 0 && buffer_.starts_with(kUtf8ByteOrderMark)) {
      buffer_.erase(0, kUtf8ByteOrderMark.size());
    }
    return true;
  }
}

bool CsvReader::next(CsvLine& line) {
  while (read_line()) {
    ++number_;
    const std::string_view text = trim(buffer_);
    if (text.empty()) continue;
    line = CsvLine{};
    line.number = number_;
    line.text = text;
    if (text.rfind("#@", 0) == 0 && directives_) {
      const auto equals = text.find('=');
      if (equals == std::string_view::npos) fail("expected '#@ key = value'");
      line.directive = true;
      line.key = trim(text.substr(2, equals - 2));
      line.value = trim(text.substr(equals + 1));
      return true;
    }
    if (text.front() == '#') continue;
    line.fields = split_csv(text);
    return true;
  }
  return false;
}

std::string CsvReader::where() const { return name_ + ":" + std::to_string(number_); }

void CsvReader::fail(const std::string& message) const {
  throw std::runtime_error(where() + ": " + message);
}

double CsvReader::real(const CsvLine& line, std::size_t i, std::string_view column) const {
  if (i >= line.fields.size()) fail("missing " + std::string(column));
  const std::optional<double> value = parse_real(line.fields[i]);
  if (!value) {
    fail(std::string(column) + " ('" + std::string(line.fields[i]) + "') is not a finite number");
  }
  return *value;
}

}  // namespace imm::support
