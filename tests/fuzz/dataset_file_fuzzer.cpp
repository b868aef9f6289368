// SPDX-License-Identifier: Apache-2.0
// Fuzz target: a data-set file (track set or range-sensor samples) whose HDF5 payload is hostile
// but sealed with valid checksums, read by the data-set readers the trainer and imm-eval use.
//
// Findings: a crash, a hang, a sanitizer report, an exception other than FileError, an unusable
// error message, an HDF5 object left open, and a file that reads with a non-finite value.

#include <cstdint>
#include <string>

#include "fuzz/fuzz_support.hpp"
#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/range_sensor_file.hpp"

namespace {

template <class Read>
void read_expecting_file_errors(Read&& read) {
  try {
    read();
  } catch (const imm::io::FileError& error) {
    imm::fuzz::expect_usable_message(error.what(), "FileError");
  } catch (const std::exception& error) {
    imm::fuzz::finding(std::string("not a FileError: ") + error.what());
  }
  imm::fuzz::expect_no_open_hdf5_objects("reading a data-set file");
}

}  // namespace

// NOLINTNEXTLINE(readability-identifier-naming): the entry point libFuzzer calls
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace imm;
  static const fuzz::ScratchFile file("dataset.h5");
  fuzz::silence_hdf5();
  fuzz::write_sealed(file, fuzz::payload_of(data, size), datasets::kDatasetFormat);
  read_expecting_file_errors([&] {
    const datasets::TrackSetFile read = datasets::read_track_set(file.path());
    for (const auto& track : read.set.tracks) {
      if (!track.truth.allFinite() || !track.plots.allFinite()) {
        fuzz::finding("a track set read with non-finite values");
      }
    }
  });
  read_expecting_file_errors([&] {
    const datasets::RangeSensorDataset read = datasets::read_range_sensor_dataset(file.path());
    if (!read.data.positions.allFinite() || !read.data.outputs.allFinite()) {
      fuzz::finding("range-sensor samples read with non-finite values");
    }
  });
  return 0;
}
