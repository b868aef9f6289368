// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The command line every tool shares (header-only: each tool links CLI11 itself).
///
///   CLI::App app{"…"};
///   imm::support::standard_options(app, "imm-track");  // before adding options and subcommands
///   app.add_option("--threads", threads, "…")->check(imm::support::at_least(1));
///   if (const auto exit = imm::support::parse(app, argc, argv)) return *exit;
///
/// --version prints the tool, the project version, the model-file schema version and the git
/// revision it was built from; --help shows every option's default; a usage error prints one line
/// naming the option, with the closest subcommand for a mistyped one, and exits 1 (CLI11's own
/// exit codes 105–109 never reach the shell).

#include <CLI/CLI.hpp>
#include <algorithm>
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "imm/build_info.hpp"
#include "imm/support/edit_distance.hpp"
#include "imm/support/exit_codes.hpp"
#include "imm/version.hpp"

namespace imm::support {

/// "imm-track 0.1.0 (model schema 1, git 3773557)".
/// An error message as one line: control bytes (a newline or an ESC that came with a name or a
/// file's text) written as \n, \r, \t or \xNN; other bytes, UTF-8 included, as they are.
[[nodiscard]] inline std::string one_line(std::string_view message) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  out.reserve(message.size());
  for (const char c : message) {
    const auto u = static_cast<unsigned char>(c);
    if (u == '\n') {
      out += "\\n";
    } else if (u == '\r') {
      out += "\\r";
    } else if (u == '\t') {
      out += "\\t";
    } else if (u < 0x20 || u == 0x7f) {
      out += "\\x";
      out.push_back(kHex[u >> 4U]);
      out.push_back(kHex[u & 0xfU]);
    } else {
      out.push_back(c);
    }
  }
  return out;
}

[[nodiscard]] inline std::string version_text(std::string_view tool) {
  return std::string(tool) + ' ' + kVersion + " (model schema " +
         std::to_string(kModelSchemaVersion) + ", git " + kBuildVersion + ')';
}

/// --version, and defaults shown in --help for the options added after this call.
inline void standard_options(CLI::App& app, std::string_view tool) {
  app.set_version_flag("--version", version_text(tool), "print the version and exit");
  app.option_defaults()->always_capture_default();
  app.name(std::string(tool));
}

/// The name among `candidates` closest to `word`, if it is close enough to be a typo.
[[nodiscard]] inline std::optional<std::string> closest(
    std::string_view word, const std::vector<std::string>& candidates) {
  std::optional<std::string> best;
  std::size_t best_distance = std::max<std::size_t>(2, word.size() / 3) + 1;  // beyond: no typo
  for (const std::string& candidate : candidates) {
    const std::size_t d = edit_distance(word, candidate);
    if (d < best_distance) {
      best = candidate;
      best_distance = d;
    }
  }
  return best;
}

/// A numeric option's closed range, with a message a person reads: "must be in [1e-06, 36000] s
/// (got 0)"; NaN and infinities are outside it.
[[nodiscard]] inline CLI::Validator within(double minimum, double maximum, std::string_view unit) {
  std::ostringstream bound;
  bound.precision(15);  // a count's bound as 1000000, not 1e+06
  bound << '[' << minimum << ", " << maximum << ']';
  if (!unit.empty()) bound << ' ' << unit;
  const std::string text = bound.str();
  return CLI::Validator(
      [minimum, maximum, text](std::string& value) -> std::string {
        double number = 0.0;
        if (!CLI::detail::lexical_cast(value, number))
          return "must be a number (got " + value + ")";
        if (!(number >= minimum && number <= maximum))
          return "must be in " + text + " (got " + value + ")";
        return {};
      },
      "in " + text);
}

/// A numeric option's lower bound, with a message a person reads: "must be ≥ 1 (got 0)".
[[nodiscard]] inline CLI::Validator at_least(double minimum) {
  std::ostringstream bound;
  bound << minimum;
  const std::string text = bound.str();
  return CLI::Validator(
      [minimum, text](std::string& value) -> std::string {
        double number = 0.0;
        if (!CLI::detail::lexical_cast(value, number))
          return "must be a number (got " + value + ")";
        if (!(number >= minimum)) return "must be ≥ " + text + " (got " + value + ")";
        return {};
      },
      "≥ " + text);
}

/// A numeric option that must be positive: "must be > 0 (got -1)".
[[nodiscard]] inline CLI::Validator positive() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        double number = 0.0;
        if (!CLI::detail::lexical_cast(value, number))
          return "must be a number (got " + value + ")";
        if (!(number > 0.0)) return "must be > 0 (got " + value + ")";
        return {};
      },
      "> 0");
}

/// A seed: a whole number in [0, 2⁶⁴ − 1], written in digits. CLI11 reads "-1" into an unsigned
/// integer as 2⁶⁴ − 1 and a number past 2⁶⁴ − 1 as 2⁶⁴ − 1: "must be a whole number in [0,
/// 18446744073709551615] (got -1)". std::from_chars into an unsigned type takes digits alone (no
/// sign, no exponent) and says when they overflow.
[[nodiscard]] inline CLI::Validator seed() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        std::uint64_t number = 0;
        const char* end = value.data() + value.size();
        const auto [at, error] = std::from_chars(value.data(), end, number);
        if (error != std::errc{} || at != end) {
          return "must be a whole number in [0, 18446744073709551615] (got " + value + ")";
        }
        return {};
      },
      "in [0, 2^64 - 1]");
}

/// `code`, or kBadInput with a line on stderr where standard output could not be written (a full
/// disk, a closed pipe): a tool's tables and JSON are its output, and a script must not take a cut
/// one for the whole. A failing code is kept.
[[nodiscard]] inline int with_output_written(std::string_view tool, int code) {
  if (std::cout.flush()) return code;
  std::cerr << tool << ": writing standard output failed\n";
  return code == exit_code::kOk ? exit_code::kBadInput : code;
}

namespace detail {

// The subcommand names of `app` (aliases included).
inline std::vector<std::string> subcommand_names(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
    names.push_back(sub->get_name());
    for (const std::string& alias : sub->get_aliases()) names.push_back(alias);
  }
  return names;
}

// The deepest (sub)command that was selected, and the first argument after it on the command
// line that is neither an option nor one of its subcommands.
inline std::string usage_message(const CLI::App& app, int argc, const char* const* argv,
                                 const CLI::ParseError& error) {
  const CLI::App* current = &app;
  for (int i = 1; i < argc; ++i) {
    const std::string word = argv[i];
    if (word.empty() || word[0] == '-') break;  // options come after the command words
    const std::vector<std::string> names = subcommand_names(*current);
    if (names.empty()) break;
    if (std::find(names.begin(), names.end(), word) != names.end()) {
      current = current->get_subcommand(word);
      continue;
    }
    std::string message = "unknown command '" + word + "'";
    if (const auto match = closest(word, names)) message += "; did you mean '" + *match + "'?";
    return message;
  }
  return error.what();
}

}  // namespace detail

/// Parses the command line. Empty: go on. Otherwise the exit code: 0 after --help or --version,
/// exit_code::kUsage (1) after a usage error (printed to stderr as "tool: message").
[[nodiscard]] inline std::optional<int> parse(CLI::App& app, int argc, const char* const* argv) {
  try {
    app.parse(argc, argv);
    return std::nullopt;
  } catch (const CLI::Success& done) {
    (void)app.exit(done);
    return 0;
  } catch (const CLI::ParseError& error) {
    std::cerr << app.get_name() << ": " << detail::usage_message(app, argc, argv, error) << '\n'
              << "Run with --help for more information.\n";
    return exit_code::kUsage;
  }
}
[[nodiscard]] inline std::optional<int> parse(CLI::App& app, int argc, char** argv) {
  return parse(app, argc, const_cast<const char* const*>(argv));
}

}  // namespace imm::support
