// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Starting the project's own tools and helpers (imm-train, imm-eval, gnuplot) as child processes.

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

}  // namespace imm::support
