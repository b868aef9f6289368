// SPDX-License-Identifier: Apache-2.0
#pragma once
/// What the fuzz targets share: a per-process scratch file for the input, sealing a payload into a
/// checksummed container (so the fuzzer's mutations reach HDF5 and the schema checks instead of
/// stopping at the CRC), and the one way a target reports a finding (abort, which libFuzzer and the
/// replay driver both treat as a failure, with the reason on stderr).

#include <hdf5.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "imm/io/container_file.hpp"

namespace imm::fuzz {

/// Reports a finding and aborts.
[[noreturn]] inline void finding(const std::string& what) {
  std::fprintf(stderr, "FUZZ FINDING: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

/// A file of this process under /dev/shm (memory) when it exists, else the temp folder; removed at
/// exit. Each input overwrites it.
class ScratchFile {
 public:
  explicit ScratchFile(const std::string& name) {
    std::error_code error;
    const std::filesystem::path shm = "/dev/shm";
    const std::filesystem::path base =
        std::filesystem::is_directory(shm, error) ? shm : std::filesystem::temp_directory_path();
    dir_ = base / ("immtrain-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    path_ = dir_ / name;
  }
  ~ScratchFile() {
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;

  void write(std::string_view bytes) const {
    std::ofstream out(path_, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out) finding("cannot write the scratch file " + path_.string());
  }
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path dir_, path_;
};

/// The input as a container payload: a whole container (a seed taken from models/) loses its
/// header, anything else is the payload itself.
[[nodiscard]] inline std::string_view payload_of(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  constexpr std::string_view kMagic = "IMMTRAIN CONTAINER ";
  if (bytes.size() >= io::kContainerHeaderBytes && bytes.substr(0, kMagic.size()) == kMagic) {
    return bytes.substr(io::kContainerHeaderBytes);
  }
  return bytes;
}

/// Writes `payload` behind an empty user block and seals it as a container of `format`: valid
/// checksums around whatever the fuzzer made of the HDF5 part.
inline void write_sealed(const ScratchFile& file, std::string_view payload,
                         std::string_view format) {
  std::string bytes(io::kContainerHeaderBytes, '\0');
  bytes.append(payload);
  file.write(bytes);
  io::seal_container(file.path(), format);
}

/// Silences HDF5's error printing once per process (the readers turn failures into FileError).
inline void silence_hdf5() {
  static const bool silenced = [] { return H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr) >= 0; }();
  (void)silenced;
}

/// A reader must close everything it opened, on the error path as on success.
inline void expect_no_open_hdf5_objects(std::string_view after) {
  const ssize_t open = H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL);
  if (open != 0) {
    finding(std::to_string(open) + " HDF5 objects left open after " + std::string(after));
  }
}

/// An error message a person can act on: non-empty, one line.
inline void expect_usable_message(std::string_view what, std::string_view context) {
  if (what.empty() || what.find('\n') != std::string_view::npos) {
    finding(std::string(context) + ": unusable error message '" + std::string(what) + "'");
  }
}

}  // namespace imm::fuzz
