// SPDX-License-Identifier: Apache-2.0
#pragma once
// The subcommands of imm-eval: each parses its options into the experiment's options struct
// (imm/evaluation/experiments.hpp) and runs it; an exception becomes a message on stderr and
// exit code 2.

#include <CLI/CLI.hpp>

namespace imm::eval_tool {

/// Adds every experiment's subcommand to `app`; the one that runs leaves its exit code in
/// `exit_code`.
void add_commands(CLI::App& app, int& exit_code);

}  // namespace imm::eval_tool
