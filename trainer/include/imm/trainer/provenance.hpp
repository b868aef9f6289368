// SPDX-License-Identifier: Apache-2.0
#pragma once
/// What every trainer stamps into its outputs: provenance for model files and the
/// `<model>.metrics.json` written beside them.

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <utility>

#include "imm/datasets/regime.hpp"
#include "imm/io/model_file.hpp"

namespace imm::trainer {

/// Provenance with this build's version and the current time filled in.
[[nodiscard]] io::Provenance make_provenance(std::string model_kind, std::string config_toml,
                                             std::int64_t seed, std::string dataset_digest);
/// The same with the regime trained for (name, text, digest).
[[nodiscard]] io::Provenance make_provenance(std::string model_kind, std::string config_toml,
                                             std::int64_t seed, std::string dataset_digest,
                                             const datasets::Regime& regime);
/// The provenance of a model a trainer's config made: its kind, the config's text, seed and regime,
/// and the digest of the data it was trained on.
template <class TrainingConfig>
[[nodiscard]] io::Provenance provenance_of(std::string_view model_kind,
                                           const TrainingConfig& config,
                                           std::string dataset_digest) {
  return make_provenance(std::string(model_kind), config.text,
                         static_cast<std::int64_t>(config.seed), std::move(dataset_digest),
                         config.regime);
}
/// Records the regime in a provenance.
void set_regime(io::Provenance& provenance, const datasets::Regime& regime);

/// The start of a model's metrics file (metrics_path): its kind, the model file and the config
/// that made it; each trainer adds its figures.
[[nodiscard]] nlohmann::json metrics_of(std::string_view model_kind,
                                        const std::filesystem::path& model,
                                        const std::string& config);
/// `<folder>/<stem>.metrics.json` for a model file path.
[[nodiscard]] std::filesystem::path metrics_path(const std::filesystem::path& model_path);

/// Writes `text` to `path` durably: a temporary beside it, fsynced, renamed over `path`, then the
/// folder fsynced — a reader sees the old file or the new one, never a part, and after a power
/// loss the folder holds one of them whole. A write that fails removes its temporary.
void write_text_atomically(const std::filesystem::path& path, const std::string& text);

/// Copies `from` to `to` the same way: a temporary beside `to`, fsynced, a rename, the folder
/// fsynced.
void copy_atomically(const std::filesystem::path& from, const std::filesystem::path& to);

/// Moves a finished file `temp` (beside `path`, in the same folder) over `path` the same way: it
/// is fsynced, renamed, and the folder fsynced; on failure `temp` is removed.
void move_atomically(const std::filesystem::path& temp, const std::filesystem::path& path);

/// Writes JSON atomically (temporary file in the same folder, then rename).
void write_json_atomically(const std::filesystem::path& path, const nlohmann::json& document);

/// Creates the parent folder of `path` if needed (create_folders_durably).
void ensure_parent_folder(const std::filesystem::path& path);

/// Creates `folder` and its missing parents, each new entry made durable (the folder that gained it
/// fsynced).
void create_folders_durably(const std::filesystem::path& folder);

/// Removes a file (or an empty folder) and fsyncs the folder that lost it; nothing when absent.
void remove_durably(const std::filesystem::path& path);

/// fsyncs a folder (after it gained or lost an entry).
void sync_folder(const std::filesystem::path& folder);

/// Reads a whole text file; throws std::runtime_error naming the file.
[[nodiscard]] std::string read_text_file(const std::filesystem::path& path);

}  // namespace imm::trainer
