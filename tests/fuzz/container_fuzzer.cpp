// SPDX-License-Identifier: Apache-2.0
// Fuzz target: the container itself, byte for byte (header, checksums, HDF5 payload unsealed). An
// accepted file is walked completely as imm-inspect walks it: every object, every attribute, every
// dataset read.
//
// Findings: a crash, a hang, a sanitizer report, an exception other than FileError, an unusable
// error message, an HDF5 object left open.

#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz/fuzz_support.hpp"
#include "imm/io/container_file.hpp"

// NOLINTNEXTLINE(readability-identifier-naming): the entry point libFuzzer calls
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace imm;
  static const fuzz::ScratchFile file("container.h5");
  fuzz::silence_hdf5();
  file.write(std::string_view(reinterpret_cast<const char*>(data), size));
  try {
    const io::ContainerReader reader(file.path(), "");
    for (const std::string& object : reader.objects()) {
      for (const std::string& name : reader.attribute_names(object)) {
        (void)reader.attribute(object, name);
      }
      if (reader.kind(object) == io::ObjectKind::kDataset) {
        (void)reader.read(object);
      } else {
        (void)reader.children(object);
      }
    }
  } catch (const io::FileError& error) {
    fuzz::expect_usable_message(error.what(), "FileError");
  } catch (const std::exception& error) {
    fuzz::finding(std::string("not a FileError: ") + error.what());
  }
  fuzz::expect_no_open_hdf5_objects("reading a container");
  return 0;
}
