// SPDX-License-Identifier: Apache-2.0
#pragma once
/// What a trainer killed with SIGKILL leaves behind, removed by a process that outlives it.
///
/// Model files, checkpoints and JSON sidecars are written under a hidden temporary name
/// (".<name>.tmp-<pid>[-<n>]@<host>", imm/io/temporary_files.hpp) and renamed into place, so a kill
/// never leaves a partial file under an output's name; but SIGKILL runs no destructor, so a kill
/// while a file is being written leaves its temporary. guard_temporaries() forks a small guard
/// process that waits on a pipe from this one: when this process ends — normally or killed — the
/// pipe closes and the guard removes this process's temporaries from the given folders, then exits.
/// Call it once, early, before any thread starts (it forks).

#include <filesystem>
#include <vector>

namespace imm::trainer {

/// Starts the guard for `folders` (each the folder of an output file). Best effort: a guard that
/// cannot start is reported on stderr and the run goes on (the next writer in the folder removes
/// stale temporaries too).
void guard_temporaries(const std::vector<std::filesystem::path>& folders);

/// Removes the temporaries of process `pid` of this host in `folder` (another host's process of
/// the same ID is another process). Returns how many were removed.
int remove_temporaries_of(const std::filesystem::path& folder, long pid);

}  // namespace imm::trainer
