// SPDX-License-Identifier: Apache-2.0
// imm-bench-report: collects the medians of Google Benchmark JSON outputs into
// reports/bench/latest.json, beside the previous run's medians, and flags every benchmark more
// than 10 % slower than before (the nightly report shows the table). With --nightly, the last
// night's wall time of every stage that ran at least a second (reports/nightly/nights.jsonl: the
// trainings, the GA's among them, and the evaluations) is collected beside them as
// "nightly: <stage>" in s, so a slower training is flagged like a slower filter step. Run by
// `make bench`. The report records what it ran on ("machine"): the CPU model and its vendor,
// family, model and stepping (/proc/cpuinfo), its clock and logical CPU count as Google Benchmark
// measured them, its library's build type, the threads of each program (--threads NAME=N, as
// scripts/bench.sh ran it), the vector instruction set of the pack kernels (imm/math/lane_isa.hpp,
// as the benchmarks report it) and the BLAS that libblas.so.3 resolves to (the trainer links it
// through LAPACK and Ceres; the MLP's products are Eigen's own kernels, which do not call it):
//   imm-bench-report --out reports/bench/latest.json [--nightly NIGHTS.jsonl]
//                    [--threads NAME=N]… RUNTIME.json …

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

// The first "model name" of /proc/cpuinfo, or "unknown".
std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("model name", 0) == 0) {
      const std::size_t colon = line.find(':');
      if (colon != std::string::npos) return line.substr(line.find_first_not_of(' ', colon + 1));
    }
  }
  return "unknown";
}

// The processor's identity beside its name, which a hypervisor may shorten (a VM's "AMD EPYC"
// names no generation; family 25 model 17 is Zen 4, family 26 Zen 5): the vendor, family, model
// and stepping of /proc/cpuinfo's first processor, or "unknown" where it has none (not x86).
std::string cpu_signature() {
  std::ifstream in("/proc/cpuinfo");
  std::map<std::string, std::string> fields;
  for (std::string line; std::getline(in, line) && !line.empty();) {
    const std::size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::size_t key_end = line.find_last_not_of(" \t", colon == 0 ? 0 : colon - 1);
    const std::size_t value_start = line.find_first_not_of(' ', colon + 1);
    fields[line.substr(0, key_end == std::string::npos ? 0 : key_end + 1)] =
        value_start == std::string::npos ? "" : line.substr(value_start);
  }
  if (!fields.contains("cpu family") || !fields.contains("model")) return "unknown";
  return fields["vendor_id"] + " family " + fields["cpu family"] + " model " + fields["model"] +
         " stepping " + fields["stepping"];
}

// Where libblas.so.3 leads (Debian's alternatives: ATLAS, OpenBLAS, the reference BLAS), or
// "none found".
std::string blas_library() {
  for (const char* dir : {"/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib"}) {
    const fs::path candidate = fs::path(dir) / "libblas.so.3";
    std::error_code error;
    const fs::path resolved = fs::canonical(candidate, error);
    if (!error) return resolved.string();
  }
  return "none found";
}

// The machine of a run: the first benchmark output's context beside what only this host knows.
json machine_of(const fs::path& first_output, const json& threads) {
  std::ifstream in(first_output);
  const json doc = json::parse(in);
  const json context = doc.value("context", json::object());
  json machine = {{"cpu_model", cpu_model()},
                  {"cpu_signature", cpu_signature()},
                  {"logical_cpus", context.value("num_cpus", 0)},
                  {"mhz_per_cpu", context.value("mhz_per_cpu", 0.0)},
                  {"cpu_scaling_enabled", context.value("cpu_scaling_enabled", false)},
                  {"benchmark_library_build", context.value("library_build_type", "")},
                  {"blas", blas_library()},
                  // The vector instruction set the pack kernels ran on (imm-bench --lane_isa).
                  {"lane_isa", context.value("lane_isa", std::string("unrecorded"))},
                  {"threads", threads}};
  return machine;
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
    json threads = json::object();
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      if (arg == "--out" && i + 1 < argc) {
        out = argv[++i];
      } else if (arg == "--nightly" && i + 1 < argc) {
        nights = argv[++i];
      } else if (arg == "--threads" && i + 1 < argc) {
        const std::string value = argv[++i];
        const std::size_t equals = value.find('=');
        if (equals == std::string::npos) throw std::runtime_error("--threads needs NAME=N");
        threads[value.substr(0, equals)] = std::stoi(value.substr(equals + 1));
      } else if (arg == "--help" || arg == "-h") {
        std::cout << "usage: imm-bench-report --out LATEST.json [--nightly NIGHTS.jsonl] "
                     "[--threads NAME=N]... BENCHMARK_OUTPUT.json...\n";
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
    doc["machine"] = machine_of(inputs.front(), threads);
    const json& m = doc["machine"];
    std::printf(
        "machine: %s (%s), %d logical CPUs at %.0f MHz, BLAS %s, pack kernels %s, threads %s\n",
        m["cpu_model"].get<std::string>().c_str(), m["cpu_signature"].get<std::string>().c_str(),
        m["logical_cpus"].get<int>(), m["mhz_per_cpu"].get<double>(),
        m["blas"].get<std::string>().c_str(), m["lane_isa"].get<std::string>().c_str(),
        threads.dump().c_str());
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
