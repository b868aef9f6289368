// SPDX-License-Identifier: Apache-2.0
// The morning report's first screen and its trends: what changed last night and what to do about
// each item, whether anything shipped got worse, every shipped model's headline metric over its
// promotions, and the nightly's wall time per stage over the last nights (reports/nightly/
// nights.jsonl, one line per night). Plots are inline SVG: the HTML stays one self-contained file.

#include "nightly_trends.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include "imm/pipeline/registry.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::pipeline {

namespace {

std::string number(double value, int digits = 4) {
  std::ostringstream text;
  text.precision(digits);
  text << value;
  return text.str();
}

// The manifest's entries by name, as the registry reads them ({} when it does not read: the report
// is written whatever the manifest's state).
std::map<std::string, RegistryEntry> shipped_models(const fs::path& registry) {
  std::map<std::string, RegistryEntry> models;
  try {
    const Registry read(registry);
    for (const RegistryEntry& entry : read.entries()) models[entry.name] = entry;
  } catch (const std::exception&) {
    models.clear();
  }
  return models;
}

// What a reader does about a stage's outcome.
std::string what_to_do(const StageOutcome& o) {
  if (o.failed && o.transient)
    return "Nothing: not the model's fault (killed, out of room); the next night retries.";
  if (o.failed) {
    return "Read its log (" +
           (o.log.empty() ? std::string("the report below") : o.log.string() + ".err") +
           ") and reproduce it with the command below; the shipped model stays meanwhile.";
  }
  if (o.held_back) {
    return "Compare it with the shipped model below; if the change is wanted, ship it with "
           "`imm-train promote`, otherwise nothing: the shipped model stays.";
  }
  if (o.known_failure)
    return "Nothing while it does not get worse: the plan knows this gate fails, and why.";
  if (o.status.starts_with("promoted"))
    return "Nothing: it passed its gates and is not worse than what it replaced.";
  if (o.kind == "tracker" && !o.status.starts_with("unchanged"))
    return "Nothing: the regime's tracker changed to the better filter.";
  if (o.finding)
    return "Nothing unless it surprises: the regime ships its classical bar where a learned model "
           "does not beat it.";
  return "";
}

// Whether the outcome is news for the first screen.
bool is_news(const StageOutcome& o) {
  if (o.failed || o.held_back || o.known_failure) return true;
  if (o.kind == "model") return o.status.starts_with("promoted");
  if (o.kind == "tracker") return !o.status.starts_with("unchanged") && !o.cached;
  return o.kind == "evaluation" && o.finding &&
         o.message.find("no longer happens") != std::string::npos;
}

// An inline SVG of values with their intervals over x = 0 … n − 1, labelled below.
std::string svg_series(const std::vector<double>& value, const std::vector<double>& lower,
                       const std::vector<double>& upper, const std::vector<std::string>& labels,
                       const std::string& title) {
  constexpr double kWidth = 420, kHeight = 150, kLeft = 60, kRight = 10, kTop = 20, kBottom = 30;
  const auto [lowest, highest] = std::minmax_element(value.begin(), value.end());
  double lo = *lowest, hi = *highest;
  for (std::size_t i = 0; i < value.size(); ++i) {
    lo = std::min({lo, value[i], lower[i]});
    hi = std::max({hi, value[i], upper[i]});
  }
  if (hi - lo < 1e-12 * std::max(1.0, std::abs(hi))) {
    lo -= 0.5 * std::max(1e-9, std::abs(lo) * 0.01);
    hi += 0.5 * std::max(1e-9, std::abs(hi) * 0.01);
  }
  const std::size_t n = value.size();
  const auto x = [&](std::size_t i) {
    return kLeft + (n == 1 ? 0.5 : static_cast<double>(i) / static_cast<double>(n - 1)) *
                       (kWidth - kLeft - kRight);
  };
  const auto y = [&](double v) { return kTop + (hi - v) / (hi - lo) * (kHeight - kTop - kBottom); };
  std::ostringstream svg;
  svg.precision(5);
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << kWidth << "\" height=\"" << kHeight
      << "\" role=\"img\"><title>" << title << "</title>"
      << "<text x=\"" << kLeft << "\" y=\"13\" font-size=\"11\">" << title << "</text>"
      << "<text x=\"2\" y=\"" << y(hi) + 4 << "\" font-size=\"10\">" << number(hi) << "</text>"
      << "<text x=\"2\" y=\"" << y(lo) + 4 << "\" font-size=\"10\">" << number(lo) << "</text>"
      << "<line x1=\"" << kLeft << "\" y1=\"" << kTop << "\" x2=\"" << kLeft << "\" y2=\""
      << kHeight - kBottom << "\" stroke=\"#999\"/>";
  std::string path;
  for (std::size_t i = 0; i < n; ++i) {
    path += (i == 0 ? "M" : " L") + number(x(i), 6) + " " + number(y(value[i]), 6);
    svg << "<line x1=\"" << x(i) << "\" y1=\"" << y(lower[i]) << "\" x2=\"" << x(i) << "\" y2=\""
        << y(upper[i]) << "\" stroke=\"#4a7ab5\"/><circle cx=\"" << x(i) << "\" cy=\""
        << y(value[i]) << "\" r=\"3\" fill=\"#1f4e8c\"><title>" << labels[i] << ": "
        << number(value[i]) << " [" << number(lower[i]) << ", " << number(upper[i])
        << "]</title></circle>";
  }
  svg << "<path d=\"" << path << "\" fill=\"none\" stroke=\"#1f4e8c\" stroke-width=\"1\"/>";
  svg << "<text x=\"" << kLeft << "\" y=\"" << kHeight - 8 << "\" font-size=\"10\">"
      << labels.front() << "</text>";
  if (n > 1) {
    svg << "<text x=\"" << kWidth - kRight << "\" y=\"" << kHeight - 8
        << "\" font-size=\"10\" text-anchor=\"end\">" << labels.back() << "</text>";
  }
  svg << "</svg>";
  return svg.str();
}

// The headline metric of a manifest entry: its experiment's first error metric (ζ_p, an RMSE, …),
// not a consistency ratio.
std::optional<std::string> headline_of(const nlohmann::json& metrics) {
  for (const auto& [name, value] : metrics.items()) {
    if (name.find("nees") != std::string::npos || name.find("nis") != std::string::npos) continue;
    if (!value.is_object() || !value.contains("value")) continue;
    return name;
  }
  return std::nullopt;
}

}  // namespace

std::string markdown_to_html(const std::string& text) {
  std::ostringstream html;
  std::istringstream lines(text);
  bool in_table = false, in_list = false;
  for (std::string line; std::getline(lines, line);) {
    const bool row = line.starts_with("|");
    const bool item = line.starts_with("  - ") || line.starts_with("- ");
    if (row && line.find_first_not_of("|-: ") == std::string::npos) continue;  // |---|---|
    if (row != in_table) html << (row ? "<table>" : "</table>");
    if (item != in_list) html << (item ? "<ul>" : "</ul>");
    in_table = row;
    in_list = item;
    if (item) {
      html << "<li>" << html_text(line.substr(line.find("- ") + 2)) << "</li>";
    } else if (row) {
      html << "<tr>";
      std::string cell;
      std::istringstream cells(line.substr(1));
      while (std::getline(cells, cell, '|')) {
        const auto first = cell.find_first_not_of(' '), last = cell.find_last_not_of(' ');
        html << "<td>"
             << html_text(first == std::string::npos ? "" : cell.substr(first, last - first + 1))
             << "</td>";
      }
      html << "</tr>";
    } else if (!line.empty()) {
      html << "<p>" << html_text(line) << "</p>";
    }
  }
  if (in_table) html << "</table>";
  if (in_list) html << "</ul>";
  return html.str();
}

std::string html_text(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

void record_night(const fs::path& history, const std::string& night, const NightlyResult& result) {
  nlohmann::json stages = nlohmann::json::object();
  for (const auto& o : result.stages) {
    if (!o.cached) stages[o.kind + " " + o.name] = o.wall_seconds;
  }
  const nlohmann::json line = {{"night", night},
                               {"exit_code", result.exit_code},
                               {"wall_seconds", result.wall_seconds},
                               {"stages", stages}};
  trainer::create_folders_durably(history.parent_path());
  append_line(history, line.dump());
}

void append_line(const fs::path& file, const std::string& line) {
  const int fd = ::open(file.c_str(), O_RDWR | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error(file.string() + ": cannot append: " + std::strerror(errno));
  std::string text = line + '\n';
  // A line cut short by a kill or a full disk ends without its newline: it is closed first, so
  // that it stays one unreadable line and this one reads whole.
  struct stat info {};
  if (::fstat(fd, &info) == 0 && info.st_size > 0) {
    char last = '\n';
    if (::pread(fd, &last, 1, info.st_size - 1) == 1 && last != '\n') text.insert(0, 1, '\n');
  }
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t n = ::write(fd, text.data() + written, text.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string why = std::strerror(errno);
      ::close(fd);
      throw std::runtime_error(file.string() + ": cannot append: " + why);
    }
    written += static_cast<std::size_t>(n);
  }
  const bool synced = ::fsync(fd) == 0;
  ::close(fd);
  if (!synced) throw std::runtime_error(file.string() + ": fsync: " + std::strerror(errno));
}

void write_first_screen(const NightlyResult& result, const fs::path& registry,
                        std::ostringstream& md, std::ostringstream& html) {
  const auto shipped = shipped_models(registry);
  const auto regime_of = [&](const StageOutcome& o) -> std::string {
    if (o.kind == "tracker") return o.name;
    const std::string model = o.kind == "evaluation" ? o.name.substr(o.name.find(' ') + 1) : o.name;
    const auto it = shipped.find(model);
    return it == shipped.end() || it->second.regime_name.empty() ? "–" : it->second.regime_name;
  };
  std::vector<const StageOutcome*> news;
  std::vector<std::string> unchanged;
  for (const auto& o : result.stages) {
    if (is_news(o)) {
      news.push_back(&o);
    } else if (o.kind == "model") {
      unchanged.push_back(o.name);
    }
  }
  std::stable_sort(news.begin(), news.end(), [&](const auto* a, const auto* b) {
    const auto rank = [](const StageOutcome* o) { return o->failed ? 0 : o->held_back ? 1 : 2; };
    return rank(a) < rank(b);
  });
  md << "## Last night\n\n";
  html << "<h2>Last night</h2>\n";
  if (news.empty()) {
    md << "No news: every model ties the one it would replace.\n\n";
    html << "<p>No news: every model ties the one it would replace.</p>\n";
  } else {
    md << "| regime | stage | what happened | what to do |\n|---|---|---|---|\n";
    html << "<table id=\"news\"><tr><th>regime</th><th>stage</th><th>what happened</th><th>what to "
            "do</th></tr>\n";
    for (const StageOutcome* o : news) {
      const std::string summary = o->message.substr(0, o->message.find('\n'));
      md << "| " << regime_of(*o) << " | " << o->kind << " " << o->name << " | **" << o->status
         << "**" << (summary.empty() ? "" : ": " + summary) << " | " << what_to_do(*o) << " |\n";
      const char* css = o->failed ? " class=\"failed\"" : o->held_back ? " class=\"held\"" : "";
      html << "<tr><td>" << html_text(regime_of(*o)) << "</td><td>" << o->kind << " "
           << html_text(o->name) << "</td><td><b" << css << ">" << html_text(o->status) << "</b>"
           << (summary.empty() ? "" : ": " + html_text(summary)) << "</td><td>"
           << html_text(what_to_do(*o)) << "</td></tr>\n";
    }
    html << "</table>\n";
    md << "\n";
  }
  std::size_t held = 0, promoted = 0;
  for (const auto& o : result.stages) {
    held += o.held_back;
    promoted += o.kind == "model" && o.status.starts_with("promoted");
  }
  std::ostringstream worse;
  worse << "Did anything shipped get worse? "
        << (held == 0 ? "No: " : "No shipped file changed for the worse: ") << promoted
        << " model(s) promoted, each not worse than the one it replaced beyond the "
        << "interval and the plan's margin"
        << (held == 0 ? ""
                      : "; " + std::to_string(held) +
                            " candidate(s) worse than the shipped "
                            "model were held back, and those stay")
        << ".";
  if (!unchanged.empty()) {
    worse << " Unchanged (the candidate ties the shipped model, or was not rerun): "
          << unchanged.size() << " model(s).";
  }
  md << worse.str() << "\n\n";
  html << "<p id=\"worse\">" << html_text(worse.str()) << "</p>\n";
}

void write_trends(const fs::path& registry, const fs::path& history, std::ostringstream& md,
                  std::ostringstream& html, std::size_t nights) {
  md << "\n## Trends\n\n";
  html << "<h2>Trends</h2>\n";
  std::vector<nlohmann::json> lines;  // the nights, oldest first
  {
    std::ifstream in(history);
    for (std::string line; std::getline(in, line);) {
      auto document = nlohmann::json::parse(line, nullptr, false);
      if (!document.is_discarded() && document.contains("stages")) lines.push_back(document);
    }
  }
  // A model's training cost: its stage's wall time in the last night that ran it.
  const auto training_seconds = [&](const std::string& name) -> std::string {
    for (auto night = lines.rbegin(); night != lines.rend(); ++night) {
      const auto& stages = night->at("stages");
      if (stages.contains("model " + name))
        return number(stages.at("model " + name).get<double>(), 3);
    }
    return "–";
  };
  // Every shipped model's headline metric over its promotions, oldest first: the history (which
  // the registry keeps newest first) reversed, then the shipped entry.
  md << "Every shipped model's headline metric at each promotion, with its 95 % interval (lower "
        "is better), beside its training cost (the wall time of its stage, training and "
        "evaluations, "
        "in the last night that ran it):\n\n| model | metric | promotions | first | now | "
        "training s |\n|---|---|---|---|---|---|\n";
  html << "<p>Every shipped model's headline metric at each promotion, with its 95 % interval "
          "(lower is better; hover a point for its value), and its training cost (the wall time of "
          "its stage in the last night that ran it):</p>\n<div id=\"metric-trends\">\n";
  for (const auto& [name, entry] : shipped_models(registry)) {
    std::vector<const RegistryEntry*> promotions;
    for (auto old = entry.history.rbegin(); old != entry.history.rend(); ++old)
      promotions.push_back(&*old);
    promotions.push_back(&entry);
    const auto metric = headline_of(entry.metrics);
    if (!metric) continue;
    std::vector<double> value, lower, upper;
    std::vector<std::string> labels;
    for (const RegistryEntry* p : promotions) {
      if (!p->metrics.contains(*metric)) continue;
      const auto& m = p->metrics.at(*metric);
      value.push_back(m.value("value", 0.0));
      const auto interval = m.value("interval", nlohmann::json::array());
      lower.push_back(interval.size() == 2 ? interval[0].get<double>() : value.back());
      upper.push_back(interval.size() == 2 ? interval[1].get<double>() : value.back());
      labels.push_back(p->promoted_utc.empty() ? "?" : p->promoted_utc.substr(0, 10));
    }
    if (value.empty()) continue;
    md << "| " << name << " | " << *metric << " | " << value.size() << " | "
       << number(value.front()) << " | " << number(value.back()) << " | " << training_seconds(name)
       << " |\n";
    html << svg_series(
                value, lower, upper, labels,
                html_text(name + ": " + *metric + " (training " + training_seconds(name) + " s)"))
         << "\n";
  }
  html << "</div>\n";
  // The nightly's wall time per stage over the last nights.
  if (lines.size() > nights) lines.erase(lines.begin(), lines.end() - static_cast<long>(nights));
  md << "\nWall time per stage over the last " << lines.size()
     << " night(s) (s; ⚠ more than 10 % above its median of the nights before, and above 5 s):\n\n";
  html << "<p>Wall time per stage over the last " << lines.size()
       << " night(s) (s; ⚠ more than 10 % above its median of the nights before, and above 5 s):"
          "</p>\n";
  if (lines.empty()) return;
  std::map<std::string, std::vector<std::optional<double>>> seconds;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    for (const auto& [stage, s] : lines[i].at("stages").items()) {
      auto& row = seconds[stage];
      row.resize(lines.size());
      row[i] = s.get<double>();
    }
  }
  md << "| stage |";
  html << "<table id=\"wall-times\"><tr><th>stage</th>";
  for (const auto& line : lines) {
    md << ' ' << line.value("night", "?") << " |";
    html << "<th>" << html_text(line.value("night", "?")) << "</th>";
  }
  md << "\n|---|";
  for (std::size_t i = 0; i < lines.size(); ++i) md << "---|";
  md << "\n";
  html << "</tr>\n";
  for (auto& [stage, row] : seconds) {
    row.resize(lines.size());
    std::vector<double> before;
    for (std::size_t i = 0; i + 1 < row.size(); ++i) {
      if (row[i]) before.push_back(*row[i]);
    }
    std::sort(before.begin(), before.end());
    const bool slower = row.back() && !before.empty() && *row.back() > 5.0 &&
                        *row.back() > 1.1 * before[before.size() / 2];
    md << "| " << stage << " |";
    html << "<tr><td>" << html_text(stage) << "</td>";
    for (std::size_t i = 0; i < row.size(); ++i) {
      const std::string cell =
          row[i] ? number(*row[i], 3) + (i + 1 == row.size() && slower ? " ⚠" : "") : "–";
      md << ' ' << cell << " |";
      html << "<td>" << cell << "</td>";
    }
    md << "\n";
    html << "</tr>\n";
  }
  html << "</table>\n";
}

}  // namespace imm::pipeline
