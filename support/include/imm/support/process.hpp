// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Starting the project's own tools and helpers (imm-train, imm-eval, gnuplot) as child processes,
/// and the running process's memory policy.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace imm::support {

/// Runs `executable` (a path, or a bare name looked up in PATH) with `arguments`; returns its exit
/// code, or 128 + signal when it was killed. With `log`, stdout and stderr go to `log`.out and
/// `log`.err instead of the terminal.
int run_process(const std::filesystem::path& executable, const std::vector<std::string>& arguments,
                const std::optional<std::filesystem::path>& log = std::nullopt);

/// The folder of the running executable (where the sibling tools are).
[[nodiscard]] std::filesystem::path executable_folder();

/// Makes the process keep the memory it frees for its next allocations (glibc: blocks up to 32 MB
/// come from the heap instead of their own mappings, and the heap is handed back to the kernel only
/// beyond 128 MB free). A training that builds and frees the same buffers at every step (the GA's
/// checkpoint: 1.2 MB a generation through HDF5) otherwise pays the kernel's page faults for them
/// again every time; with it the default GA training took 9.0 s instead of 14.8
/// (docs/performance.md). Elsewhere than glibc, nothing.
void keep_freed_memory();

}  // namespace imm::support
