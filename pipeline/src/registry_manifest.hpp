// SPDX-License-Identifier: Apache-2.0
#pragma once
// The registry's manifest as text (registry_manifest.cpp); parse_manifest, model_file_problem and
// quoted_for_message are public (imm/pipeline/registry.hpp).

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "imm/pipeline/registry.hpp"

namespace imm::pipeline {

/// metrics_sha256 of a model shipped without a metrics file.
inline constexpr std::string_view kNoMetrics = "none";

/// The manifest's text for `entries` (what Registry::commit writes).
[[nodiscard]] std::string manifest_text(const std::vector<RegistryEntry>& entries);

/// The manifest's text: a regular file (never a FIFO, a device or a link) of at most
/// kMaxManifestBytes, or nothing when there is none; std::runtime_error naming the file otherwise.
[[nodiscard]] std::optional<std::string> read_manifest_text(const std::filesystem::path& path);

}  // namespace imm::pipeline
