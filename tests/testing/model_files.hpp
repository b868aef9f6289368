// SPDX-License-Identifier: Apache-2.0
#pragma once
/// A model file written the way the tests need one: a kind, what goes in it, committed.

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <utility>

#include "imm/io/model_file.hpp"

namespace imm::testing {

/// Writes a model file of `kind` at `path` (length unit m) with what `fill` writes into it, then
/// commits it; `trainer_version` goes into its provenance.
inline void write_model(const std::filesystem::path& path, std::string_view kind,
                        const std::function<void(io::ModelFileWriter&)>& fill,
                        std::string trainer_version = {}) {
  io::Provenance provenance;
  provenance.model_kind = std::string(kind);
  provenance.trainer_version = std::move(trainer_version);
  io::ModelFileWriter writer(path, provenance);
  fill(writer);
  writer.commit();
}

}  // namespace imm::testing
