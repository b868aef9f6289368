// SPDX-License-Identifier: Apache-2.0
// imm-bench-report: collects the medians of Google Benchmark JSON outputs into
// reports/bench/latest.json, beside the previous run's medians, and flags every benchmark more
// than 10 % slower than before (the nightly report shows the table). With --nightly, the last
// night's wall time of every stage that ran at least a second (reports/nightly/nights.jsonl: the
// trainings, the GA's among them, and the evaluations) is collected beside them as
// "nightly: <stage>" in s, so a slower training is flagged like a slower filter step. Run by
// `make bench`:
//   imm-bench-report --out reports/bench/latest.json [--nightly NIGHTS.jsonl] RUNTIME.json …

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr double kSlowdown = 0.10;

// name → (median, unit) of one Google Benchmark output: the "median" aggregates when the run had
// repetitions, the single iteration rows otherwise.
std::map<std::string, std::pair<double, std::string>> medians(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path.string());
  const json doc = json::parse(in);
  std::map<std::string, std::pair<double, std::string>> out, single;
  for (const auto& row : doc.at("benchmarks")) {
    if (row.contains("error_occurred") && row.at("error_occurred").get<bool>()) {
      throw std::runtime_error(path.string() + ": " + row.value("name", "?") +
                               " failed its result check: " + row.value("error_message", ""));
    }
    const std::string unit = row.value("time_unit", "ns");
    if (row.value("run_type", "") == "aggregate") {
      if (row.value("aggregate_name", "") == "median")
        out[row.at("run_name").get<std::string>()] = {row.at("real_time").get<double>(), unit};
    } else {
      single[row.at("name").get<std::string>()] = {row.at("real_time").get<double>(), unit};
    }
  }
  return out.empty() ? single : out;
}

// "nightly: <stage>" → (seconds, "s") of the last night of a nights.jsonl, the stages that ran
// at least a second (cached ones are not in it).
std::map<std::string, std::pair<double, std::string>> last_night(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path.string());
  json last;
  for (std::string line; std::getline(in, line);) {
    if (line.empty()) continue;
    auto document = json::parse(line, nullptr, false);
    if (document.is_discarded() || !document.contains("stages")) {
      throw std::runtime_error(path.string() + ": a line that is not a night's record");
    }
    last = std::move(document);
  }
  std::map<std::string, std::pair<double, std::string>> out;
  if (last.is_null()) return out;
  for (const auto& [stage, seconds] : last.at("stages").items()) {
    if (seconds.get<double>() >= 1.0) out["nightly: " + stage] = {seconds.get<double>(), "s"};
  }
  return out;
}

std::string utc_now() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    fs::path out, nights;
    std::vector<fs::path> inputs;
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      if (arg == "--out" && i + 1 < argc) {
        out = argv[++i];
      } else if (arg == "--nightly" && i + 1 < argc) {
        nights = argv[++i];
      } else if (arg == "--help" || arg == "-h") {
        std::cout << "usage: imm-bench-report --out LATEST.json [--nightly NIGHTS.jsonl] "
                     "BENCHMARK_OUTPUT.json...\n";
        return 0;
      } else {
        inputs.emplace_back(arg);
      }
    }
    if (out.empty() || inputs.empty()) {
      std::cerr << "usage: imm-bench-report --out LATEST.json BENCHMARK_OUTPUT.json...\n";
      return 1;
    }
    std::map<std::string, double> previous;
    std::string previous_date;
    if (fs::exists(out)) {
      std::ifstream in(out);
      const json old = json::parse(in);
      previous_date = old.value("generated", "");
      for (const auto& row : old.at("benchmarks")) previous[row.at("name")] = row.at("median");
    }
    json doc;
    doc["generated"] = utc_now();
    doc["previous_run"] = previous_date;
    doc["slowdown_threshold"] = kSlowdown;
    doc["benchmarks"] = json::array();
    int flagged = 0;
    std::printf("%-48s %14s %14s %9s\n", "benchmark (median)", "now", "before", "change");
    std::vector<std::map<std::string, std::pair<double, std::string>>> tables;
    tables.reserve(inputs.size() + 1);
    for (const auto& input : inputs) tables.push_back(medians(input));
    if (!nights.empty()) tables.push_back(last_night(nights));
    for (const auto& table : tables) {
      for (const auto& [name, value] : table) {
        json row = {{"name", name}, {"median", value.first}, {"unit", value.second}};
        std::string before = "-", change = "-";
        if (const auto it = previous.find(name); it != previous.end() && it->second > 0.0) {
          const double ratio = value.first / it->second - 1.0;
          row["previous"] = it->second;
          row["change"] = ratio;
          row["slower"] = ratio > kSlowdown;
          flagged += ratio > kSlowdown ? 1 : 0;
          before = std::to_string(it->second);
          change = std::to_string(static_cast<int>(std::lround(100.0 * ratio))) + " %" +
                   (ratio > kSlowdown ? " SLOWER" : "");
        }
        std::printf("%-48s %11.4g %-2s %14s %9s\n", name.c_str(), value.first, value.second.c_str(),
                    before.c_str(), change.c_str());
        doc["benchmarks"].push_back(row);
      }
    }
    fs::create_directories(out.parent_path().empty() ? fs::path(".") : out.parent_path());
    const fs::path temp = out.string() + ".tmp";
    std::ofstream(temp, std::ios::trunc) << doc.dump(1) << "\n";
    fs::rename(temp, out);
    std::printf("%s: %zu benchmarks, %d more than %.0f %% slower than the previous run\n",
                out.string().c_str(), doc["benchmarks"].size(), flagged, 100 * kSlowdown);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "imm-bench-report: " << e.what() << "\n";
    return 2;
  }
}
