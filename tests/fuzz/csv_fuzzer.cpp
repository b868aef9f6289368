// SPDX-License-Identifier: Apache-2.0
// Fuzz target: the CSV readers — imm-track's measurements, imm-train import-rules' rule tables
// (against the GA paper config's filter settings), imm-train tsk --data's sensor samples and
// imm-data import's recordings (read, then put on their grid and cut into windows) — on the same
// text.
//
// Findings: a crash, a hang, a sanitizer report, an exception that is not a std::runtime_error
// naming the problem, an unusable message, or a value accepted that the reader's contract refuses
// (a row reported good with a non-finite value, a rule table or sample set with one).

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <sstream>
#include <string>
#include <string_view>

#include "fuzz/fuzz_support.hpp"
#include "imm/datasets/range_sensor_file.hpp"
#include "imm/datasets/recorded.hpp"
#include "imm/support/measurement_csv.hpp"
#include "imm/trainer/ga/ga_config.hpp"
#include "imm/trainer/model_files/import_rules.hpp"

namespace {

template <class Read>
void read_expecting_runtime_errors(std::string_view reader, Read&& read) {
  try {
    read();
  } catch (const std::runtime_error& error) {
    imm::fuzz::expect_usable_message(error.what(), reader);
  } catch (const std::exception& error) {
    imm::fuzz::finding(std::string(reader) + ": unexpected exception: " + error.what());
  }
}

const imm::trainer::ga::GaTrainingConfig& ga_config() {
  static const auto config = imm::trainer::ga::load_ga_config(
      std::filesystem::path(IMM_SOURCE_DIR) / "configs/ga_fuzzy_imm.toml",
      std::filesystem::path(IMM_SOURCE_DIR) / "configs/regimes/paper/ga_imm_training.toml");
  return config;
}

}  // namespace

// NOLINTNEXTLINE(readability-identifier-naming): the entry point libFuzzer calls
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace imm;
  static const fuzz::ScratchFile file("input.csv");
  const std::string text(reinterpret_cast<const char*>(data), size);
  file.write(text);
  read_expecting_runtime_errors("measurement csv", [&] {
    std::istringstream in(text);
    support::MeasurementCsv csv = support::read_measurement_csv(in, "fuzz.csv");
    // A good row has its index column: k, or a finite t that scans_from_times turns into k.
    for (const support::MeasurementRow& row : csv.rows) {
      const bool indexed = csv.timed ? row.time && std::isfinite(*row.time) : row.scan.has_value();
      if (row.problem.empty() && (!row.z.allFinite() || !indexed)) {
        fuzz::finding("measurement csv: line " + std::to_string(row.line) +
                      " reported good with a missing or non-finite value");
      }
      if (!row.problem.empty()) fuzz::expect_usable_message(row.problem, "measurement csv row");
    }
    support::scans_from_times(csv, 0.5, "fuzz.csv");
    for (const support::MeasurementRow& row : csv.rows) {
      if (row.problem.empty() && !row.scan) {
        fuzz::finding("measurement csv: line " + std::to_string(row.line) +
                      " reported good without a scan after scans_from_times");
      }
    }
  });
  read_expecting_runtime_errors("rules csv", [&] {
    const GaFuzzyImmSpec spec = trainer::read_rules_csv(file.path(), ga_config().filter, "km");
    spec.validate();
  });
  read_expecting_runtime_errors("recording csv", [&] {
    const auto tracks = datasets::read_recording(file.path(), {datasets::SensorKind::kCartesian});
    datasets::ImportReport report;
    const datasets::TrackSet set = datasets::import_recordings(tracks, {}, &report);
    // Every value read is finite; a gap is NaN, never ±∞; every window has its recording.
    for (std::size_t i = 0; i < set.tracks.size(); ++i) {
      if (set.tracks[i].plots.array().isInf().any()) fuzz::finding("recording: an infinite plot");
      if (set.recording.at(i) < 0 ||
          static_cast<std::size_t>(set.recording[i]) >= set.recording_names.size()) {
        fuzz::finding("recording: a window without its recording");
      }
      if (set.tracks[i].plots.rows() != set.scans) fuzz::finding("recording: a short window");
    }
  });
  read_expecting_runtime_errors("sensor samples csv", [&] {
    const datasets::RangeSensorData samples = datasets::read_sensor_samples(file.path());
    if (!samples.positions.allFinite() || !samples.outputs.allFinite()) {
      fuzz::finding("sensor samples read with non-finite values");
    }
  });
  return 0;
}
