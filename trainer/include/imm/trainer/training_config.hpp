// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Loading a trainer's TOML config: the loader reads what every config has (its regime and its
/// `seed`, by default the config type's), then `fill(root, config)` the rest; the document refuses
/// unknown keys and turns a spec's InvalidParameter into a ConfigError naming the key; the config
/// keeps its text and file name (`text`, `name`) for the model's provenance.
///
/// Every trainer config names the regime it trains for (`regime = "configs/regimes/…toml"`, a path
/// relative to the working directory); `regime_override` (the command line's `--regime`) replaces
/// it. The regime is loaded before the rest of the config, which may derive defaults from it.

#include <filesystem>
#include <optional>

#include "imm/datasets/regime_file.hpp"
#include "imm/support/config.hpp"

namespace imm::trainer {

/// The regime a config names (or the override), loaded. ConfigError on the `regime` key when it
/// is missing; a bad regime file raises its own ConfigError (naming that file and its key).
[[nodiscard]] datasets::RegimeFile regime_of(const support::ConfigTable& root,
                                             const std::optional<std::filesystem::path>& override);

/// A config of type Config on `regime` with the `seed` of `root` (the type's default without one),
/// then `fill(root, config)` its own keys: every trainer's config is made so.
template <class Config, class Fill>
[[nodiscard]] Config config_on(const support::ConfigTable& root, const datasets::Regime& regime,
                               Fill&& fill) {
  Config config;
  config.regime = regime;
  config.seed = root.seed_or("seed", config.seed);
  fill(root, config);
  return config;
}

template <class Config, class Fill>
[[nodiscard]] Config load_training_config(
    const std::filesystem::path& path, Fill&& fill,
    const std::optional<std::filesystem::path>& regime_override = std::nullopt) {
  const auto document = support::ConfigDocument::load(path);
  Config config = document->load_checked([&] {
    return config_on<Config>(document->root(), regime_of(document->root(), regime_override).regime,
                             fill);
  });
  config.text = document->text();
  config.name = path.string();
  return config;
}

}  // namespace imm::trainer
