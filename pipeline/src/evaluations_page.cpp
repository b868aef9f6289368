// SPDX-License-Identifier: Apache-2.0
// The page of the evaluations of what is shipped (docs/evaluations.md): every evaluation and
// tracker stage's report, a section rewritten only when its model or tracker is promoted.
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>

#include "imm/pipeline/nightly.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::pipeline {

namespace fs = std::filesystem;

namespace {

// The sections of an evaluations page by their stage heading line ("## tracker agile_air", one of
// `headings`: a report's own headings inside a section are not), each with its text up to the
// next stage heading.
std::map<std::string, std::string> page_sections(const fs::path& page,
                                                 const std::set<std::string>& headings) {
  std::map<std::string, std::string> sections;
  std::ifstream in(page);
  std::string heading, text;
  for (std::string line; std::getline(in, line);) {
    if (headings.contains(line)) {
      if (!heading.empty()) sections[heading] = text;
      heading = line;
      text.clear();
      continue;
    }
    if (!heading.empty()) text += line + '\n';
  }
  if (!heading.empty()) sections[heading] = text;
  return sections;
}

const StageOutcome* outcome_of_stage(const NightlyResult& result, const std::string& kind,
                                     const std::string& name) {
  const StageOutcome* found = nullptr;
  for (const auto& o : result.stages) {
    if (o.kind == kind && o.name == name) found = &o;
  }
  return found;
}

}  // namespace

void write_evaluations_page(const fs::path& page, const NightlyPlan& plan,
                            const NightlyResult& result) {
  // The page describes what is shipped: a section is rewritten when the night promoted its model
  // (or its tracker), or when the page has none yet; otherwise the shipped model's section stays
  // as it was, so a night that keeps every model leaves the page byte for byte.
  std::set<std::string> headings;
  for (const NightlyStage& stage : plan.stages) {
    if (stage.kind != "evaluation" && stage.kind != "tracker") continue;
    headings.insert("## " + std::string(stage.kind == "tracker" ? "tracker " : "") + stage.name);
  }
  const std::map<std::string, std::string> before = page_sections(page, headings);
  std::ostringstream md;
  md << "# Latest evaluations\n\n"
     << "Written by the nightly (`imm-train all`) from the report of every evaluation and tracker "
        "stage, in the plan's order, never by hand: a section is rewritten when its model or "
        "tracker is promoted, so the page describes what is shipped. Differences carry their "
        "95 % paired-bootstrap interval over tracks, and \"beats\" means the interval excludes "
        "zero. Each night's stages, candidates, promotions and benchmarks are in its morning "
        "report (reports/nightly/latest/).\n";
  for (const NightlyStage& stage : plan.stages) {
    if (stage.kind != "evaluation" && stage.kind != "tracker") continue;
    const std::string heading =
        "## " + std::string(stage.kind == "tracker" ? "tracker " : "") + stage.name;
    md << '\n' << heading << '\n';
    const StageOutcome* outcome = outcome_of_stage(result, stage.kind, stage.name);
    const StageOutcome* shipping =
        stage.kind == "tracker" ? outcome : outcome_of_stage(result, "model", stage.model);
    const bool promoted = shipping != nullptr && shipping->status.starts_with("promoted");
    if (const auto kept = before.find(heading); kept != before.end() && !promoted) {
      // Its text without the blank lines that separated it from the next heading (written again
      // below), so that keeping a section is idempotent.
      std::string text = kept->second;
      while (text.size() > 1 && text.ends_with("\n\n")) text.pop_back();
      md << text;
      continue;
    }
    md << '\n';
    if (outcome == nullptr) {
      md << "Not run this night.\n";
      continue;
    }
    if (!outcome->command.empty()) md << "`" << outcome->command << "` — ";
    md << outcome->status << " (exit " << outcome->exit_code << ")";
    if (outcome->cached) md << ", unchanged since " << outcome->night;
    md << "\n\n";
    const fs::path report = (stage.kind == "tracker" ? stage.report : stage.out) / "report.md";
    std::ifstream in(report);
    if (!in) {
      md << "No report (" << report.generic_string() << ")"
         << (outcome->message.empty() ? "" : ": " + outcome->message) << ".\n";
      continue;
    }
    for (std::string line; std::getline(in, line);) {
      if (line.starts_with("#")) md << '#';  // under this page's stage heading
      md << line << '\n';
    }
  }
  const std::string text = md.str();
  std::ifstream old(page, std::ios::binary);
  const std::string previous{std::istreambuf_iterator<char>(old), std::istreambuf_iterator<char>()};
  if (text != previous) trainer::write_text_atomically(page, text);
}

}  // namespace imm::pipeline
