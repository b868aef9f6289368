// SPDX-License-Identifier: Apache-2.0
#pragma once
// The morning report's first screen and trends (nightly_trends.cpp). Not installed.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>

#include "imm/pipeline/nightly.hpp"

namespace imm::pipeline {

namespace fs = std::filesystem;

/// Text for HTML (&, <, >, " escaped).
[[nodiscard]] std::string html_text(const std::string& text);
/// A note as HTML: its Markdown table rows as a table, its "- " lines as a list, its other lines
/// as paragraphs, every text escaped. The notes are the product's own text in exactly these three
/// forms, so a Markdown library is not used: CommonMark's cmark (libcmark-dev) has no tables, and
/// cmark-gfm's table extension would render the same three forms through an extension registry
/// and a raw-HTML policy to configure.
[[nodiscard]] std::string markdown_to_html(const std::string& text);
/// Appends the night's line to `history` (JSON lines: night, exit code, wall time, each stage that
/// ran and its seconds).
void record_night(const fs::path& history, const std::string& night, const NightlyResult& result);
/// Appends one line to an append-only history and fsyncs it; a line a torn append left without its
/// newline is closed first, so it never swallows this one.
void append_line(const fs::path& file, const std::string& line);
/// What changed last night (promoted, held back, failed, known failures, tracker changes), per
/// regime, with what to do about each; whether anything shipped got worse.
void write_first_screen(const NightlyResult& result, const fs::path& registry,
                        std::ostringstream& md, std::ostringstream& html);
/// Every shipped model's headline metric over its promotions (inline SVG with intervals) and the
/// wall time of each stage over the last `nights` nights of `history`, slowdowns flagged.
void write_trends(const fs::path& registry, const fs::path& history, std::ostringstream& md,
                  std::ostringstream& html, std::size_t nights = 14);

}  // namespace imm::pipeline
