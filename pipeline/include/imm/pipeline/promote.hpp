// SPDX-License-Identifier: Apache-2.0
#pragma once
/// `imm-train promote FILE --name NAME --reason TEXT`: ships a model file past the nightly's gates,
/// deliberately. The nightly promotes only what passes its quality gates and is not worse than the
/// shipped model; a person may decide otherwise (a schema change that needs every file rewritten,
/// a difference they judged immaterial), and the registry records that decision: the manifest
/// entry carries the reason, `imm-inspect --manifest` shows it, and
/// `imm-train rollback` undoes it like any promotion.
///
/// Refused, with the file unchanged: a file that does not read (every field, and the filter it
/// builds), a file written by a build of uncommitted code (trainer_version "…-dirty"), an empty
/// reason, a name of another kind than the entry it replaces.

#include <filesystem>
#include <string>

#include "imm/pipeline/registry.hpp"

namespace imm::pipeline {

struct PromoteOptions {
  std::filesystem::path file;                 ///< the model file to ship
  std::string name;                           ///< the registry entry (nightly stage name)
  std::string reason;                         ///< why, in a sentence
  std::filesystem::path registry = "models";  ///< the models folder
};

/// Promotes `options.file` as `options.name` with its metrics file (<stem>.metrics.json) when there
/// is one; returns the new entry. Throws std::runtime_error (or io::FileError) saying why not.
RegistryEntry promote_by_hand(const PromoteOptions& options);

}  // namespace imm::pipeline
