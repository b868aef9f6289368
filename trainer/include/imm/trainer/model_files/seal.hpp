// SPDX-License-Identifier: Apache-2.0
#pragma once
/// `imm-train seal FILE`: re-seals a model file whose HDF5 content was edited with other tools
/// (h5py, h5edit), deliberately. The container checksum then matches the edited bytes again, but
/// only if the content still reads as a valid model: the sealed copy is checked with the kind's
/// reader (and, for the kinds the runtime loads, imm::load_filter) before it replaces the file
/// (temporary + rename: a failed seal leaves the file as it was).

#include <filesystem>
#include <string>

namespace imm::trainer {

struct SealResult {
  std::string kind;    ///< the model kind of the sealed file
  std::string before;  ///< what the check said before sealing ("intact" or the error)
  std::string sha256;  ///< of the sealed file
};

/// Throws io::FileError (naming the file and the field) when the content does not read as a
/// model; the file is then unchanged.
SealResult seal_model_file(const std::filesystem::path& path);

/// Reads a model file with its kind's reader and, for the kinds the runtime loads, builds its
/// filter (imm::load_filter); returns the kind. Throws io::FileError naming the field.
std::string check_model_file(const std::filesystem::path& path);

}  // namespace imm::trainer
