// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The temporary files of atomic writes: ".<name>.tmp-<pid>[-<n>]@<host>" beside the file they
/// are renamed over. A process killed while writing (SIGKILL runs no destructor) leaves one; the
/// next writer in the folder, the trainer's guard and the nightly remove it — but only when it is
/// known dead: written on *this* host by a process that no longer exists. A folder shared between
/// machines (a sweep under `srun`, a registry on NFS) holds other hosts' in-flight files, whose
/// process IDs mean nothing here. A name without "@<host>" (written before hosts were recorded)
/// counts as this host's.

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "imm/runtime_export.hpp"

namespace imm::io {

/// This machine's name as temporaries carry it (gethostname, characters outside [A-Za-z0-9._-]
/// replaced by '_').
[[nodiscard]] IMM_RUNTIME_EXPORT const std::string& this_host();

/// The temporary beside `target` for this process (and `counter`, when one process writes several
/// at once).
[[nodiscard]] IMM_RUNTIME_EXPORT std::filesystem::path temporary_beside(
    const std::filesystem::path& target, std::optional<unsigned> counter = std::nullopt);

/// What a temporary's name says about its writer.
struct TemporaryWriter {
  long pid = 0;      ///< the writing process
  std::string host;  ///< its host; this_host() for a name without one
};
/// The writer of a temporary file name, or nothing when the name is not a temporary's.
[[nodiscard]] IMM_RUNTIME_EXPORT std::optional<TemporaryWriter> temporary_writer(
    std::string_view file_name);

/// Whether a temporary file name is a temporary of this host whose process no longer exists.
[[nodiscard]] IMM_RUNTIME_EXPORT bool is_stale_temporary(std::string_view file_name);

}  // namespace imm::io
