// imm-track: runs a plain IMM over a measurement CSV — a client of imm::runtime alone.
//
//   imm-track --filter configs/track/cv3_imm.toml --measurements plots.csv [--out track.csv]
//   imm-track --filter models/cv3_imm.h5 --measurements plots.csv
//
// Writes per input row: k, status (waiting|initialized|updated|rejected), the combined state,
// its covariance diagonal and the mode probabilities. Rows that cannot be used are reported on
// stderr with their line number and leave the filter untouched.
// Exit codes: 0 success, 1 usage, 2 unreadable or invalid filter or measurement file.

#include <CLI/CLI.hpp>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>

#include "imm/filters/tracker.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/support/config.hpp"
#include "imm/support/measurement_csv.hpp"
#include "imm/support/plain_imm_config.hpp"

namespace {

constexpr int kExitBadInput = 2;

bool is_container(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char magic[8] = {};
  in.read(magic, sizeof magic);
  return in.gcount() == sizeof magic && std::string_view(magic, sizeof magic) == "IMMTRAIN";
}

imm::PlainImmSpec load_filter(const std::string& path) {
  if (is_container(path)) return imm::io::read_plain_imm(path);
  return imm::support::load_plain_imm_config(path);
}

std::vector<std::string> state_names(int dimension) {
  if (dimension == 4) return {"x", "vx", "y", "vy"};
  return {"x", "vx", "ax", "y", "vy", "ay"};
}

void write_number(std::ostream& out, double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.10g", value);
  out << buffer;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Run a plain IMM (TOML config or plain_imm model file) over a measurement CSV."};
  std::string filter_path, measurements_path, out_path;
  std::int64_t max_gap = imm::PlainImmTracker::kDefaultMaxGap;
  app.add_option("--filter", filter_path, "filter: TOML config or plain_imm model file")
      ->required();
  app.add_option("--measurements", measurements_path, "CSV with k,zx,zy or k,range,azimuth")
      ->required();
  app.add_option("--out", out_path, "output CSV (default: standard output)");
  app.add_option("--max-gap", max_gap, "scans without a plot before the track is restarted")
      ->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);

  imm::PlainImmSpec spec;
  imm::support::MeasurementCsv csv;
  try {
    spec = load_filter(filter_path);
    std::ifstream in(measurements_path);
    if (!in) throw std::runtime_error(measurements_path + ": cannot open");
    csv = imm::support::read_measurement_csv(in, measurements_path);
    if (csv.kind != spec.measurement.kind) {
      throw std::runtime_error(measurements_path + ": holds " +
                               std::string(imm::to_string(csv.kind)) +
                               " measurements but the filter expects " +
                               std::string(imm::to_string(spec.measurement.kind)));
    }
  } catch (const std::exception& error) {
    std::cerr << "imm-track: " << error.what() << '\n';
    return kExitBadInput;
  } catch (...) {
    std::cerr << "imm-track: unexpected error\n";
    return kExitBadInput;
  }

  std::ofstream file_out;
  if (!out_path.empty()) {
    file_out.open(out_path);
    if (!file_out) {
      std::cerr << "imm-track: cannot write " << out_path << '\n';
      return kExitBadInput;
    }
  }
  std::ostream& out = out_path.empty() ? std::cout : file_out;

  imm::PlainImmTracker tracker(spec, max_gap);
  const int n = tracker.state_dimension();
  const auto names = state_names(n);
  out << "k,status";
  for (const auto& name : names) out << ',' << name;
  for (const auto& name : names) out << ",var_" << name;
  for (const auto& mode : spec.modes) out << ",mu_" << mode.name;
  out << '\n';

  Eigen::VectorXd mean(n), variance(n);
  std::size_t rejected = 0;
  for (const auto& row : csv.rows) {
    if (!row.problem.empty()) {
      std::cerr << measurements_path << ':' << row.line << ": " << row.problem
                << "; row not used\n";
    }
    if (!row.scan) {
      ++rejected;
      continue;
    }
    const imm::TrackStepResult result = tracker.process(*row.scan, row.z);
    if (result.event == imm::TrackEvent::kRejected) {
      ++rejected;
      if (row.problem.empty()) {
        std::cerr << measurements_path << ':' << row.line << ": " << result.reason
                  << "; row not used\n";
      }
    }
    out << *row.scan << ',' << imm::to_string(result.event);
    if (tracker.initialized()) {
      tracker.state(mean, variance);
      for (int i = 0; i < n; ++i) out << ',', write_number(out, mean(i));
      for (int i = 0; i < n; ++i) out << ',', write_number(out, variance(i));
      const imm::ModeVector mu = tracker.mode_probabilities();
      for (int j = 0; j < mu.size(); ++j) out << ',', write_number(out, mu(j));
    } else {
      for (int i = 0; i < 2 * n + tracker.mode_count(); ++i) out << ',';
    }
    out << '\n';
  }
  if (rejected > 0) std::cerr << "imm-track: " << rejected << " row(s) not used\n";
  return 0;
}
