// SPDX-License-Identifier: Apache-2.0
// Fuzz target: a model file whose HDF5 payload is hostile but sealed with valid checksums (the
// container header is public), read by every kind's runtime reader. The input is the payload (a
// whole container from models/ is accepted as a seed: its header is dropped); the target seals it
// itself, so every mutation reaches HDF5 and the schema checks.
//
// Findings: a crash, a hang, a sanitizer report; an exception other than FileError (or an
// InvalidParameter from a filter the reader let through); an error message that is empty or spans
// lines; an HDF5 object left open; and a model that loads but whose filter, stepped on plausible
// plots, produces a non-finite or invalid estimate (an invalid value accepted silently).

#include <cstdint>
#include <string>

#include "fuzz/fuzz_support.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/io/model_file.hpp"
#include "testing/kind_filters.hpp"

// NOLINTNEXTLINE(readability-identifier-naming): the entry point libFuzzer calls
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace imm;
  static const fuzz::ScratchFile file("model.h5");
  fuzz::silence_hdf5();
  fuzz::write_sealed(file, fuzz::payload_of(data, size), io::kModelFormat);
  std::string problem;
  try {
    const io::ModelFileReader reader(file.path());
    testing::KindFilter made = testing::make_kind_filter(reader);
    problem = testing::exercise(made);
  } catch (const io::FileError& error) {
    fuzz::expect_usable_message(error.what(), "FileError");
    if (error.file() != file.path().string()) fuzz::finding("FileError names another file");
  } catch (const InvalidParameter& error) {
    fuzz::finding(std::string("the reader accepted a value the filter refuses: ") + error.what());
  } catch (const std::exception& error) {
    fuzz::finding(std::string("not a FileError: ") + error.what());
  }
  if (!problem.empty()) fuzz::finding("accepted silently: " + problem);
  fuzz::expect_no_open_hdf5_objects("reading a model file");
  return 0;
}
