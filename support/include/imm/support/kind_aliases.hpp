// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Commands named after a model kind answer to the kind's own name too: `imm-train ga` is also
/// `imm-train ga_fuzzy_imm`, `imm-eval fimm` also `imm-eval tsk_sensor`. The names come from the
/// registry of model kinds (imm/model_kinds.hpp), so a kind's command and its files share one
/// name while the short names stay accepted.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <vector>

#include "imm/model_kinds.hpp"

namespace imm::support {

/// Adds to every subcommand of `app` whose name is a model kind's alias the kind's name, unless
/// another subcommand already answers to it. Call after the subcommands are added.
inline void alias_model_kinds(CLI::App& app) {
  const std::vector<CLI::App*> commands =
      app.get_subcommands([](const CLI::App*) { return true; });
  for (CLI::App* command : commands) {
    const ModelKind* kind = find_model_kind(command->get_name());
    if (kind == nullptr || kind->name == command->get_name()) continue;
    const bool taken = std::any_of(commands.begin(), commands.end(),
                                   [&](const CLI::App* c) { return c->check_name(kind->name); });
    if (!taken) command->alias(kind->name);
  }
}

}  // namespace imm::support
