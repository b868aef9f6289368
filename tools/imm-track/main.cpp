// SPDX-License-Identifier: Apache-2.0
// imm-track: runs any model file's filter (or a plain IMM TOML config) over a measurement CSV — a
// client of imm::runtime alone (imm::load_filter).
//
//   imm-track --filter configs/track/cv3_imm.toml --measurements plots.csv [--out track.csv]
//   imm-track --filter models/ga_fuzzy_imm.h5 --measurements plots.csv
//
// The CSV's first column is the scan k, or the time t in s. A filter that predicts over any
// interval (a plain IMM without a learned schedule) takes the times as they come; a model of one
// sample period holds them to it (a file recorded at another period is refused naming the column).
// The model's sample period, length unit and plot noise are printed on stderr, since a CSV cannot
// say its units.
// Writes per input row: k (or t), status (waiting|initialized|updated|rejected), the combined
// state, its covariance diagonal and the mode probabilities, every number in its shortest form that
// reads back to the same double. Rows that cannot be used are reported on stderr with their line
// number and leave the filter untouched.
// Exit codes: 0 success, 1 usage, 2 unreadable or invalid filter or measurement file.

#include <CLI/CLI.hpp>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

#include "imm/io/container_file.hpp"
#include "imm/load.hpp"
#include "imm/support/cli.hpp"
#include "imm/support/config.hpp"
#include "imm/support/exit_codes.hpp"
#include "imm/support/measurement_csv.hpp"
#include "imm/support/plain_imm_config.hpp"
#include "imm/tracking/tracker.hpp"

namespace {

bool is_container(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char magic[8] = {};
  in.read(magic, sizeof magic);
  return in.gcount() == sizeof magic && std::string_view(magic, sizeof magic) == "IMMTRAIN";
}

// A model file of any kind, or a plain IMM TOML config.
imm::LoadedFilter load_filter(const std::string& path, std::int64_t max_gap) {
  std::error_code error;
  if (!std::filesystem::exists(path, error)) {
    throw std::runtime_error(path + ": no such model file or config");
  }
  if (is_container(path)) return imm::load_filter(path, max_gap);
  const imm::PlainImmSpec spec = imm::support::load_plain_imm_config(path);
  return {imm::make_plain_imm_filter(spec), spec.track_options(max_gap), {}};
}

// "ga_fuzzy_imm model for agile_air: sample period 1 s, lengths in m, Cartesian plots with
// σ = 25 m, 25 m".
std::string describe(const imm::LoadedFilter& loaded) {
  const imm::io::Provenance& p = loaded.provenance;
  const std::string unit = p.model_kind.empty() ? "the config's unit" : p.length_unit;
  std::ostringstream text;
  text.precision(6);
  text << (p.model_kind.empty() ? std::string("plain IMM config") : p.model_kind + " model")
       << (p.regime_name.empty() ? "" : " for " + p.regime_name) << ": sample period "
       << loaded.options.sample_period << " s, lengths in " << unit << ", ";
  const Eigen::Matrix2d& R = loaded.options.measurement_covariance;
  if (loaded.options.measurement_kind == imm::MeasurementKind::kPolar) {
    text << "polar plots with σ = " << std::sqrt(R(0, 0)) << ' ' << unit << " (range), "
         << std::sqrt(R(1, 1)) << " rad (azimuth)";
  } else {
    text << "Cartesian plots with σ = " << std::sqrt(R(0, 0)) << ' ' << unit << ", "
         << std::sqrt(R(1, 1)) << ' ' << unit;
  }
  return text.str();
}

// A mode name as a CSV column: "x.lane change" → "x.lane_change".
std::string column_name(std::string name) {
  for (char& c : name) {
    if (c == ' ' || c == ',') c = '_';
  }
  return name;
}

// The shortest text that reads back to the same double (std::to_chars).
void write_number(std::ostream& out, double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  out.write(buffer, result.ptr - buffer);
}

}  // namespace

int main(int argc, char** argv) {
  imm::io::skip_hdf5_shutdown_at_exit();  // before any HDF5 call (container_file.hpp)
  CLI::App app{
      "Run a model file's filter (any kind) or a plain IMM TOML config over a measurement "
      "CSV."};
  imm::support::standard_options(app, "imm-track");
  std::string filter_path, measurements_path, out_path;
  std::int64_t max_gap = imm::kDefaultMaxGap;
  app.add_option("--filter", filter_path, "model file (any kind) or plain IMM TOML config")
      ->required();
  app.add_option(
         "--measurements", measurements_path,
         "CSV with k,zx,zy, k,range,azimuth or k,z1,z2 (the model's own plot space); t for k: "
         "times in s; named columns after those are not read (imm-data export's truth)")
      ->required();
  app.add_option("--out", out_path, "output CSV (default: standard output)");
  app.add_option(
         "--max-gap", max_gap,
         "scans (sample periods, for a t column) without a plot before the track is restarted "
         "(at most 1000000)")
      ->check(imm::support::at_least(1));
  if (const auto exit = imm::support::parse(app, argc, argv)) return *exit;

  imm::LoadedFilter loaded;
  imm::support::MeasurementCsv csv;
  std::vector<std::string> modes;
  std::optional<imm::Tracker> built;
  bool by_time = false;  // a t column fed as times (process_at)
  try {
    loaded = load_filter(filter_path, max_gap);
    // The tracker is built here, inside the error handling: settings the file holds (its
    // envelope's) are checked again by the tracker's own constructor.
    modes.reserve(static_cast<std::size_t>(loaded.filter->mode_count()));
    for (int j = 0; j < loaded.filter->mode_count(); ++j) {
      modes.push_back(column_name(loaded.filter->mode_name(j)));
    }
    built.emplace(std::move(loaded.filter), loaded.options);
    std::ifstream in(measurements_path);
    if (!in) throw std::runtime_error(measurements_path + ": cannot open");
    csv = imm::support::read_measurement_csv(in, measurements_path);
    // What the filter assumes of the plots (the CSV cannot say its units; its t column can say
    // its period, and is held to the model's).
    std::cerr << "imm-track: " << filter_path << ": " << describe(loaded) << '\n';
    if (!csv.model_space && csv.kind != loaded.options.measurement_kind) {
      throw std::runtime_error(measurements_path + ": holds " +
                               std::string(imm::to_string(csv.kind)) +
                               " measurements but the filter expects " +
                               std::string(imm::to_string(loaded.options.measurement_kind)));
    }
    // Times as they come where the filter takes any interval; whole periods otherwise.
    by_time = csv.timed && built->filter().takes_any_interval();
    if (!by_time) {
      imm::support::scans_from_times(csv, loaded.options.sample_period, measurements_path);
    }
  } catch (const std::exception& error) {
    std::cerr << "imm-track: " << imm::support::one_line(error.what()) << '\n';
    return imm::support::exit_code::kBadInput;
  } catch (...) {
    std::cerr << "imm-track: unexpected error\n";
    return imm::support::exit_code::kBadInput;
  }

  std::ofstream file_out;
  if (!out_path.empty()) {
    file_out.open(out_path);
    if (!file_out) {
      std::cerr << "imm-track: cannot write " << out_path << '\n';
      return imm::support::exit_code::kBadInput;
    }
  }
  std::ostream& out = out_path.empty() ? std::cout : file_out;

  imm::Tracker& tracker = *built;
  const int n = tracker.state_dimension();
  const auto names = imm::state_variable_names(n);
  out << (by_time ? "t" : "k") << ",status";
  for (const auto& name : names) out << ',' << name;
  for (const auto& name : names) out << ",var_" << name;
  for (const auto& mode : modes) out << ",mu_" << mode;
  out << ",envelope_nis,outside_envelope\n";

  Eigen::VectorXd mean(n), variance(n);
  std::size_t rejected = 0;
  for (const auto& row : csv.rows) {
    if (!row.problem.empty()) {
      std::cerr << measurements_path << ':' << row.line << ": " << row.problem
                << "; row not used\n";
    }
    if (by_time ? !row.time : !row.scan) {
      ++rejected;
      continue;
    }
    const imm::TrackStepResult result =
        by_time ? tracker.process_at(*row.time, row.z) : tracker.process(*row.scan, row.z);
    if (result.event == imm::TrackEvent::kRejected) {
      ++rejected;
      if (row.problem.empty()) {
        std::cerr << measurements_path << ':' << row.line << ": " << result.reason
                  << "; row not used\n";
      }
    }
    if (by_time) {
      write_number(out, *row.time);
    } else {
      out << *row.scan;
    }
    out << ',' << imm::to_string(result.event);
    if (tracker.initialized()) {
      tracker.state(mean, variance);
      for (int i = 0; i < n; ++i) out << ',', write_number(out, mean(i));
      for (int i = 0; i < n; ++i) out << ',', write_number(out, variance(i));
      const imm::ModeVector mu = tracker.mode_probabilities();
      for (int j = 0; j < mu.size(); ++j) out << ',', write_number(out, mu(j));
    } else {
      for (int i = 0; i < 2 * n + tracker.mode_count(); ++i) out << ',';
    }
    // The envelope test (imm/tracking/envelope.hpp): the window's mean NIS, and 1 when the plots
    // no longer fit the model.
    out << ',';
    if (std::isfinite(result.envelope_nis)) write_number(out, result.envelope_nis);
    out << ',' << (result.outside_envelope ? 1 : 0) << '\n';
  }
  if (rejected > 0) std::cerr << "imm-track: " << rejected << " row(s) not used\n";
  // Buffered rows are written here: a full disk or a closed pipe is an error, not a track cut
  // short without a word.
  if (!out.flush()) {
    std::cerr << "imm-track: writing " << (out_path.empty() ? "standard output" : out_path)
              << " failed\n";
    return imm::support::exit_code::kBadInput;
  }
  return 0;
}
