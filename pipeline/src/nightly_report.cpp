// SPDX-License-Identifier: Apache-2.0
// The morning report of a nightly run: reports/nightly/<night>/index.md and a self-contained
// index.html (plots embedded), and the `latest` link beside them.

#include <openssl/evp.h>

#include <array>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "imm/io/temporary_files.hpp"
#include "imm/pipeline/nightly.hpp"
#include "imm/trainer/provenance.hpp"
#include "nightly_trends.hpp"

namespace imm::pipeline {
namespace {

namespace fs = std::filesystem;

// Standard base64 with padding (RFC 4648), by libcrypto.
std::string base64(const std::string& bytes) {
  std::string out(4 * ((bytes.size() + 2) / 3) + 1, '\0');  // and EVP_EncodeBlock's NUL
  const int written = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                      reinterpret_cast<const unsigned char*>(bytes.data()),
                                      static_cast<int>(bytes.size()));
  out.resize(static_cast<std::size_t>(written));
  return out;
}

std::string read_or_empty(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

std::string exit_meaning(int code) {
  return code == 0   ? "nothing failed, nothing held back"
         : code == 3 ? "a stage failed"
         : code == 6 ? "a candidate was held back by the regression gate"
                     : "unexpected";
}

std::string seconds_text(const StageOutcome& o) {
  if (o.cached) return "cached (" + o.night + ")";
  std::ostringstream text;
  text.precision(1);
  text << std::fixed << o.wall_seconds;
  return text.str();
}

std::string cell_text(std::string text) {
  for (char& c : text) {
    if (c == '\n' || c == '|') c = ' ';
  }
  return text;
}

std::vector<fs::path> plots_in(const fs::path& folder) {
  std::vector<fs::path> plots;
  std::error_code error;
  if (!fs::is_directory(folder, error)) return plots;
  for (const auto& f : fs::directory_iterator(folder)) {
    if (f.path().extension() == ".png") plots.push_back(f.path());
  }
  std::sort(plots.begin(), plots.end());
  return plots;
}

// The medians of the last `make bench` (reports/bench/latest.json), with their change against the
// run before and the ones more than 10 % slower flagged.
void write_benchmarks(const fs::path& latest, std::ostringstream& md, std::ostringstream& html) {
  if (!fs::exists(latest)) return;
  nlohmann::json doc;
  try {
    std::ifstream in(latest);
    doc = nlohmann::json::parse(in);
  } catch (const std::exception& e) {
    md << "\n## Benchmarks\n\n" << latest.string() << " is unreadable: " << e.what() << "\n";
    html << "<h2>Benchmarks</h2><p>" << html_text(latest.string()) << " is unreadable.</p>\n";
    return;
  }
  const std::string when = doc.value("generated", "?"), before = doc.value("previous_run", "");
  md << "\n## Benchmarks\n\n`make bench` of " << when
     << (before.empty() ? std::string() : ", against " + before)
     << " (medians; ⚠ more than 10 % slower):\n\n| benchmark | median | before | change |\n"
        "|---|---|---|---|\n";
  html << "<h2>Benchmarks</h2>\n<p><code>make bench</code> of " << html_text(when)
       << (before.empty() ? std::string() : ", against " + html_text(before))
       << " (medians; ⚠ more than 10 % slower)</p>\n<table id=\"benchmarks\"><tr><th>benchmark"
          "</th><th>median</th><th>before</th><th>change</th></tr>\n";
  for (const auto& row : doc.value("benchmarks", nlohmann::json::array())) {
    std::ostringstream median, previous, change;
    median << row.value("median", 0.0) << " " << row.value("unit", "");
    if (row.contains("previous")) {
      previous << row.value("previous", 0.0) << " " << row.value("unit", "");
      change << std::showpos << std::lround(100.0 * row.value("change", 0.0)) << " %"
             << (row.value("slower", false) ? " ⚠" : "");
    }
    const std::string name = row.value("name", "?");
    md << "| " << cell_text(name) << " | " << median.str() << " | " << previous.str() << " | "
       << change.str() << " |\n";
    html << "<tr><td>" << html_text(name) << "</td><td>" << median.str() << "</td><td>"
         << previous.str() << "</td><td>" << html_text(change.str()) << "</td></tr>\n";
  }
  html << "</table>\n";
}

// Per regime, the filter to use (the tracker stages): the winner, why, and the ranking with the
// intervals against the classical bar (the best of the regime's tuned classical filters).
void write_trackers(const NightlyResult& result, std::ostringstream& md, std::ostringstream& html) {
  bool any = false;
  for (const auto& o : result.stages) {
    if (o.kind != "tracker") continue;
    if (!any) {
      md << "## The regime's trackers\n\nThe filter to use for each regime (`models/<regime>/"
            "tracker.h5`): a learned model only when it beats the regime's classical bar — the "
            "best "
            "of its tuned classical filters — beyond the 95 % interval.\n\n";
      html << "<h2>The regime's trackers</h2>\n<p>The filter to use for each regime: a learned "
              "model only when it beats the regime's classical bar — the best of its tuned "
              "classical filters — beyond the 95 % interval.</p>\n";
      any = true;
    }
    md << "### " << o.name << " — " << o.status << "\n\n" << o.message << "\n\n";
    html << "<h3 id=\"tracker-" << html_text(o.name) << "\">" << html_text(o.name) << " — "
         << html_text(o.status) << "</h3>\n"
         << markdown_to_html(o.message) << "\n";
    const auto document =
        nlohmann::json::parse(read_or_empty(o.report / "tracker.json"), nullptr, false);
    if (document.is_discarded() || !document.contains("ranking")) continue;
    // The two criteria: ζ_p and ζ_v, or — on recorded plots without truth — the predictive NLL
    // per plot and the innovation RMS.
    const bool truth = document.value("truth", true);
    const std::array<const char*, 2> keys =
        truth ? std::array{"zeta_p", "zeta_v"} : std::array{"predictive_nll", "innovation_rms"};
    const std::array<std::string, 2> labels =
        truth ? std::array<std::string, 2>{"ζ_p", "ζ_v"}
              : std::array<std::string, 2>{"predictive NLL", "innovation RMS"};
    md << "| place | filter | " << labels[0] << " | " << labels[1] << " | this − baseline "
       << labels[0] << " [95 %] | this − baseline " << labels[1]
       << " [95 %] | against the baseline |\n|---|---|---|---|---|---|---|\n";
    html << "<table><tr><th>place</th><th>filter</th><th>" << labels[0] << "</th><th>" << labels[1]
         << "</th><th>this − baseline " << labels[0] << " [95 %]</th><th>this − baseline "
         << labels[1] << " [95 %]</th><th>against the baseline</th></tr>\n";
    for (const auto& row : document.at("ranking")) {
      const auto difference = [&](const char* metric) {
        if (!row.contains("versus_baseline") || !row.at("versus_baseline").contains(metric)) {
          return std::string("–");
        }
        const auto& d = row.at("versus_baseline").at(metric);
        std::ostringstream text;
        text.precision(4);
        text << std::fixed << std::showpos << d.at(0).get<double>() << " [" << d.at(1).get<double>()
             << ", " << d.at(2).get<double>() << "]";
        return text.str();
      };
      std::ostringstream p, v;
      p.precision(4), v.precision(4);
      p << std::fixed << row.value(keys[0], 0.0);
      v << std::fixed << row.value(keys[1], 0.0);
      const std::string name =
          row.value("filter", "?") + (row.value("baseline", false)    ? " (the classical bar)"
                                      : row.value("classical", false) ? " (classical)"
                                                                      : "");
      md << "| " << row.value("place", 0) << " | " << name << " | " << p.str() << " | " << v.str()
         << " | " << difference(keys[0]) << " | " << difference(keys[1]) << " | "
         << row.value("verdict", "") << " |\n";
      html << "<tr><td>" << row.value("place", 0) << "</td><td>" << html_text(name) << "</td><td>"
           << p.str() << "</td><td>" << v.str() << "</td><td>" << difference(keys[0]) << "</td><td>"
           << difference(keys[1]) << "</td><td>" << html_text(row.value("verdict", ""))
           << "</td></tr>\n";
    }
    md << "\n";
    html << "</table>\n";
  }
}

}  // namespace

void write_morning_report(const fs::path& folder, const NightlyPlan& plan,
                          const NightlyResult& result) {
  fs::create_directories(folder);
  const std::string night = folder.filename().string();
  std::size_t failed = 0, held = 0, cached = 0, findings = 0;
  for (const auto& o : result.stages) {
    failed += o.failed, held += o.held_back, cached += o.cached, findings += o.finding;
  }

  std::ostringstream md, html;
  md << "# Nightly " << night << "\n\nExit code **" << result.exit_code << "** ("
     << exit_meaning(result.exit_code) << "); " << result.stages.size() << " stages in "
     << static_cast<int>(result.wall_seconds) << " s: " << failed << " failed, " << held
     << " held back, " << findings << " with findings, " << cached << " cached.\n\n";
  if (!result.training.empty()) md << "Training: " << result.training << ".\n\n";
  // The first screen: what changed and what to do; then the regime's trackers, then the details.
  std::ostringstream first_html, tracker_html;
  write_first_screen(result, plan.registry, md, first_html);
  write_trackers(result, md, tracker_html);
  md << "## Stages\n\n"
     << "| kind | stage | status | wall s | note |\n|---|---|---|---|---|\n";
  html << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>Nightly "
       << night << "</title><style>body{font-family:sans-serif;max-width:1200px;margin:2em auto}"
       << "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 6px;"
       << "vertical-align:top}pre{background:#f6f6f6;padding:8px;overflow-x:auto;font-size:12px}"
       << ".failed{color:#b00020;font-weight:bold}.held{color:#b06000;font-weight:bold}"
       << "img{max-width:560px;margin:4px}</style></head><body>\n<h1>Nightly " << night
       << "</h1>\n<p id=\"summary\">Exit code <b>" << result.exit_code << "</b> ("
       << exit_meaning(result.exit_code) << "); " << result.stages.size() << " stages in "
       << static_cast<int>(result.wall_seconds) << " s: " << failed << " failed, " << held
       << " held back, " << findings << " with findings, " << cached << " cached.</p>\n";
  if (!result.training.empty()) {
    html << "<p id=\"training\">Training: " << html_text(result.training) << ".</p>\n";
  }
  html << first_html.str() << tracker_html.str();
  html << "<h2>Stages</h2>\n<table id=\"stages\">"
       << "<tr><th>kind</th><th>stage</th><th>status</th><th>wall s</th><th>note</th></tr>\n";
  for (const auto& o : result.stages) {
    // A note's first line here; the whole of it (tables included) in the sections below.
    const auto end = o.message.find('\n');
    const std::string note =
        end == std::string::npos ? o.message : o.message.substr(0, end) + " (more below)";
    md << "| " << o.kind << " | " << o.name << " | " << o.status << " | " << seconds_text(o)
       << " | " << cell_text(note) << " |\n";
    const char* css = o.failed ? " class=\"failed\"" : o.held_back ? " class=\"held\"" : "";
    html << "<tr><td>" << o.kind << "</td><td>" << html_text(o.name) << "</td><td" << css << ">"
         << html_text(o.status) << "</td><td>" << seconds_text(o) << "</td><td>" << html_text(note)
         << "</td></tr>\n";
  }
  html << "</table>\n";

  // Every failure and hold-back with its reason and the command that reproduces it.
  md << "\n## Failures and hold-backs\n\n";
  html << "<h2>Failures and hold-backs</h2>\n";
  bool any = false;
  for (const auto& o : result.stages) {
    if (!o.failed && !o.held_back) continue;
    any = true;
    // Notes are sentences and their tables are tables (the regression comparison's rows).
    md << "### " << o.kind << " " << o.name << " — " << o.status << "\n\n"
       << o.message << "\n\nReproduce: `" << o.command << "`";
    if (!o.log.empty()) md << " (logs: `" << o.log.string() << ".out`, `.err`)";
    md << "\n\n";
    html << "<h3>" << o.kind << " " << html_text(o.name) << " — " << html_text(o.status)
         << "</h3>\n"
         << markdown_to_html(o.message) << "\n<p>Reproduce: <code>" << html_text(o.command)
         << "</code></p>\n";
  }
  if (!any) {
    md << "None.\n";
    html << "<p>None.</p>\n";
  }

  // Findings: a learned model that does not beat a baseline tuned on its regime, with its numbers.
  // Not failures: the model passed its gates and went on to the regression gate.
  static constexpr const char* kFindings =
      "A learned model that does not beat a baseline tuned on its regime, or a quality gate that "
      "failed where the plan knows it fails (its known failures, each with its measured reason; "
      "nightly.toml's [[evaluations.known_failures]]): reported, not failures.";
  md << "\n## Findings\n\n" << kFindings << "\n\n";
  html << "<h2>Findings</h2>\n<p>" << html_text(kFindings) << "</p>\n";
  any = false;
  for (const auto& o : result.stages) {
    if (!o.finding) continue;
    any = true;
    md << "### " << o.name << " — " << o.status << "\n\n```\n"
       << o.message << "\n```\n\nReproduce: `" << o.command << "`\n\n";
    html << "<h3>" << html_text(o.name) << " — " << html_text(o.status) << "</h3>\n<pre>"
         << html_text(o.message) << "</pre>\n<p>Reproduce: <code>" << html_text(o.command)
         << "</code></p>\n";
  }
  if (!any) {
    md << "None.\n";
    html << "<p>None.</p>\n";
  }

  // Per model: the decision, the comparison with the shipped model, and every evaluation's
  // tables and plots.
  md << "\n## Models and evaluations\n";
  html << "<h2>Models and evaluations</h2>\n";
  for (const auto& o : result.stages) {
    if (o.kind == "model") {
      md << "\n### " << o.name << " — " << o.status << "\n\n";
      html << "<h3 id=\"model-" << html_text(o.name) << "\">" << html_text(o.name) << " — "
           << html_text(o.status) << "</h3>\n";
      if (!o.message.empty()) {
        md << o.message << "\n\n";
        html << markdown_to_html(o.message) << "\n";
      }
      continue;
    }
    if (o.kind != "evaluation") continue;
    // The evaluation's report.md, its headings nested under this section's.
    std::string tables;
    {
      std::istringstream lines(read_or_empty(o.report / "report.md"));
      for (std::string line; std::getline(lines, line);) {
        tables += (line.starts_with("#") ? "###" : "") + line + "\n";
      }
    }
    const std::string regression = read_or_empty(o.report / "regression.json").empty()
                                       ? std::string()
                                       : read_or_empty(o.report / "regression.json");
    md << "#### " << o.name << " (`" << o.report.string() << "`, " << o.status << ")\n\n"
       << tables << "\n";
    html << "<h4>" << html_text(o.name) << " (" << html_text(o.report.string()) << ", "
         << html_text(o.status) << ")</h4>\n<pre>" << html_text(tables) << "</pre>\n";
    if (!regression.empty()) {
      const auto document = nlohmann::json::parse(regression, nullptr, false);
      if (!document.is_discarded() && document.contains("metrics")) {
        md << "Against the shipped model (" << document.value("shipped_sha256", "").substr(0, 12)
           << ") on the same tracks:\n\n| metric | candidate | shipped | difference [95 %] | "
           << "verdict |\n|---|---|---|---|---|\n";
        html << "<p>Against the shipped model on the same tracks:</p><table><tr><th>metric</th>"
             << "<th>candidate</th><th>shipped</th><th>difference [95 %]</th><th>verdict</th>"
             << "</tr>\n";
        for (const auto& m : document.at("metrics")) {
          std::ostringstream diff;
          diff.precision(4);
          diff << m.value("difference", 0.0) << " [" << m.value("lower", 0.0) << ", "
               << m.value("upper", 0.0) << "]";
          md << "| " << m.value("name", "") << " | " << m.value("candidate", 0.0) << " | "
             << m.value("shipped", 0.0) << " | " << diff.str() << " | " << m.value("verdict", "")
             << " |\n";
          html << "<tr><td>" << html_text(m.value("name", "")) << "</td><td>"
               << m.value("candidate", 0.0) << "</td><td>" << m.value("shipped", 0.0) << "</td><td>"
               << diff.str() << "</td><td>" << m.value("verdict", "") << "</td></tr>\n";
        }
        md << "\n";
        html << "</table>\n";
      }
    }
    for (const auto& plot : plots_in(o.report)) {
      md << "![" << plot.filename().string() << "](" << fs::absolute(plot).string() << ")\n";
      html << "<img alt=\"" << html_text(plot.filename().string())
           << "\" src=\"data:image/png;base64," << base64(read_or_empty(plot)) << "\">\n";
    }
  }
  write_trends(plan.registry, folder.parent_path() / "nights.jsonl", md, html);
  write_benchmarks(folder.parent_path().parent_path() / "bench" / "latest.json", md, html);
  html << "</body></html>\n";

  // Durable writes through temporaries that carry their writer (pid@host), so that only a dead
  // writer's are ever removed (imm/io/temporary_files.hpp).
  trainer::write_text_atomically(folder / "index.md", md.str());
  trainer::write_text_atomically(folder / "index.html", html.str());
  // `latest` → this night.
  const fs::path latest = folder.parent_path() / "latest";
  const fs::path temp_link = io::temporary_beside(latest);
  std::error_code ignored;
  fs::remove(temp_link, ignored);
  fs::create_directory_symlink(folder.filename(), temp_link);
  try {
    fs::rename(temp_link, latest);
  } catch (...) {
    fs::remove(temp_link, ignored);
    throw;
  }
  trainer::sync_folder(latest.parent_path());
}

}  // namespace imm::pipeline
