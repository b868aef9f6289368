// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The key a config loader names when it refuses a config text: "" when it accepts it.

#include <string>

#include "imm/support/config.hpp"
#include "testing/temp_dir.hpp"

namespace imm::testing {

/// Writes `text` to a scratch file and calls `load(path)`; returns the ConfigError's key.
template <class Load>
std::string config_error_key(const std::string& text, Load&& load) {
  const TempDir dir;
  write_text(dir / "config.toml", text);
  try {
    (void)load(dir / "config.toml");
  } catch (const support::ConfigError& error) {
    return error.key();
  }
  return "";
}

}  // namespace imm::testing
