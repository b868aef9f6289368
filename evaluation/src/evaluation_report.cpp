// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/evaluation_report.hpp"

#include <fstream>
#include <iostream>
#include <optional>

#include "imm/datasets/sha256.hpp"
#include "imm/evaluation/report.hpp"
#include "imm/io/model_file.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::evaluation {
namespace {

std::string& recorded_command() {
  static std::string command;
  return command;
}

// The folder of the last metrics.json written and the report.md header made from it.
struct PendingReport {
  std::filesystem::path folder;
  std::string header;
};

std::optional<PendingReport>& pending_report() {
  static std::optional<PendingReport> report;
  return report;
}

std::string markdown_cell(std::string text) {
  for (std::size_t at = text.find('|'); at != std::string::npos; at = text.find('|', at + 2)) {
    text.replace(at, 1, "\\|");
  }
  return text;
}

std::string report_header(const nlohmann::json& metrics) {
  std::ostringstream md;
  md << "# imm-eval " << metrics.at("experiment").get<std::string>() << "\n\n"
     << "- Command: `" << metrics.at("command").get<std::string>() << "`\n"
     << "- Regime: `" << metrics.at("regime").at("name").get<std::string>() << "` (digest "
     << metrics.at("regime").at("digest").get<std::string>().substr(0, 12) << "); "
     << metrics.at("runs").get<int>() << " runs of the test split, seed "
     << metrics.at("seed").get<std::uint64_t>() << "\n"
     << "- Written: " << io::utc_now() << "\n\n## Models\n\n"
     << "| role | file | kind | trainer version | trained (UTC) | schema | SHA-256 |\n"
     << "|---|---|---|---|---|---|---|\n";
  for (const auto& m : metrics.at("models")) {
    md << "| " << m.at("role").get<std::string>() << " | " << m.at("file").get<std::string>()
       << " | " << m.value("kind", "") << " | " << m.value("trainer_version", "") << " | "
       << m.value("created_utc", "") << " | " << m.value("schema_version", 0) << " | "
       << m.value("sha256", "").substr(0, 16) << " |\n";
  }
  md << "\n## Metrics\n\n| metric | unit | definition |\n|---|---|---|\n";
  for (const auto& d : metrics.at("definitions")) {
    md << "| " << markdown_cell(d.at("name").get<std::string>()) << " | "
       << markdown_cell(d.at("unit").get<std::string>()) << " | "
       << markdown_cell(d.at("definition").get<std::string>()) << " |\n";
  }
  md << "\n## Results\n\n";
  return md.str();
}

}  // namespace

const std::string& command_line() { return recorded_command(); }

std::vector<MetricDefinition> normalized_error_definitions(const std::string& length,
                                                           const std::string& reference,
                                                           bool with_rmse) {
  std::vector<MetricDefinition> definitions = {
      {"ζ_p", "1",
       "mean over scans of P_e(k) = √(Σ_runs ‖p − p̂‖²) / √(Σ_runs ‖p − z‖²): the position error "
       "over the raw plots' (seed 000 §4); below 1 the filter beats its plots"},
      {"ζ_v", "1",
       "mean over scans of V_e(k) = √(Σ_runs ‖v − v̂‖²) / √(Σ_runs ‖v − v̄‖²), v̄ = (z(k) − "
       "z(k−1))/T the measured velocity"},
      {reference + " − this [95 %]", "1",
       "ζ of " + reference +
           " minus this filter's, with its 95 % paired-bootstrap interval over "
           "runs (same plots for every filter); below 0: " +
           reference + " is better"},
  };
  if (with_rmse) {
    definitions.push_back(
        {"position RMSE", length, "√ of the mean over runs and scans of ‖p − p̂‖²"});
    definitions.push_back(
        {"velocity RMSE", length + "/s", "√ of the mean over runs and scans of ‖v − v̂‖²"});
  }
  return definitions;
}

nlohmann::json model_provenance(const ModelUse& use) {
  nlohmann::json entry = {{"role", use.role}, {"file", use.file.generic_string()}};
  if (!std::filesystem::is_regular_file(use.file)) return entry;  // a data set, not a model
  const io::ModelFileReader reader(use.file);
  const io::Provenance& p = reader.provenance();
  entry["kind"] = p.model_kind;
  entry["sha256"] = datasets::file_sha256_hex(use.file);
  entry["trainer_version"] = p.trainer_version;
  entry["created_utc"] = p.created_utc;
  entry["schema_version"] = reader.schema_version();
  entry["regime"] = p.regime_name;
  return entry;
}

void write_metrics(const std::filesystem::path& out, const HeadlineRuns& runs,
                   const std::vector<MetricDefinition>& definitions, nlohmann::json results,
                   const std::vector<ModelUse>& more_models) {
  nlohmann::json models = nlohmann::json::array();
  if (!runs.model.empty()) models.push_back(model_provenance({"evaluated", runs.model}));
  for (const ModelUse& use : more_models) models.push_back(model_provenance(use));
  nlohmann::json defined = nlohmann::json::array();
  for (const MetricDefinition& d : definitions) {
    defined.push_back({{"name", d.name}, {"unit", d.unit}, {"definition", d.definition}});
  }
  const nlohmann::json metrics = {
      {"format", "immtrain-evaluation"},
      {"format_version", 1},
      {"experiment", runs.experiment},
      {"command", command_line()},
      {"regime", {{"name", runs.regime}, {"digest", runs.regime_digest}}},
      {"runs", runs.runs},
      {"seed", runs.seed},
      {"models", models},
      {"definitions", defined},
      {"results", std::move(results)}};
  trainer::write_json_atomically(out / "metrics.json", metrics);
  pending_report() = PendingReport{out, report_header(metrics)};
  std::string caption = std::to_string(runs.runs) + " runs, seed " + std::to_string(runs.seed);
  if (!models.empty() && models[0].contains("trainer_version")) {
    caption += ", model " + runs.model.filename().string() + " (trainer " +
               models[0]["trainer_version"].get<std::string>() + ")";
  }
  set_plot_caption(caption);
}

// A stream buffer that writes through to the terminal and keeps a copy.
class ReportRecorder::Tee : public std::streambuf {
 public:
  explicit Tee(std::streambuf* terminal) : terminal_(terminal) {}
  [[nodiscard]] std::string text() const { return copy_.str(); }

 protected:
  int overflow(int c) override {
    if (c == traits_type::eof()) return traits_type::not_eof(c);
    copy_.put(static_cast<char>(c));
    return terminal_->sputc(static_cast<char>(c));
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    copy_.write(s, n);
    return terminal_->sputn(s, n);
  }
  int sync() override { return terminal_->pubsync(); }

 private:
  std::streambuf* terminal_;
  std::ostringstream copy_;
};

ReportRecorder::ReportRecorder(int argc, const char* const* argv) {
  std::string command = "imm-eval";
  for (int i = 1; i < argc; ++i) command.append(" ").append(argv[i]);
  recorded_command() = command;
  pending_report().reset();
  original_ = std::cout.rdbuf();
  tee_ = std::make_unique<Tee>(original_);
  std::cout.rdbuf(tee_.get());
}

ReportRecorder::~ReportRecorder() { std::cout.rdbuf(original_); }

std::filesystem::path ReportRecorder::finish() {
  std::cout.flush();
  std::cout.rdbuf(original_);
  const auto& report = pending_report();
  if (!report) return {};
  std::filesystem::path path = report->folder / "report.md";
  const std::filesystem::path temp = report->folder / ".report.md.tmp";
  {
    std::ofstream md(temp, std::ios::trunc);
    md << report->header << tee_->text();
    if (!md.flush()) throw std::runtime_error(temp.string() + ": cannot write");
  }
  std::filesystem::rename(temp, path);
  return path;
}

}  // namespace imm::evaluation
