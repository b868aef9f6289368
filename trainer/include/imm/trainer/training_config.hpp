#pragma once
/// Loading a trainer's TOML config: `from(root)` builds it; the document refuses unknown keys and
/// turns a spec's InvalidParameter into a ConfigError naming the key; the config keeps its text
/// and file name (`text`, `name`) for the model's provenance.

#include <filesystem>

#include "imm/support/config.hpp"

namespace imm::trainer {

template <class Config, class From>
[[nodiscard]] Config load_training_config(const std::filesystem::path& path, From&& from) {
  const auto document = support::ConfigDocument::load(path);
  Config config = document->load_checked([&] { return from(document->root()); });
  config.text = document->text();
  config.name = path.string();
  return config;
}

}  // namespace imm::trainer
