// SPDX-License-Identifier: Apache-2.0
#pragma once
// Small regime files for trainer and tool tests, written into a test's folder.

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "testing/temp_dir.hpp"

namespace imm::testing {

// Seed 000's kind of training regime, small: km, T = 1 s, σ 0.5 km, σ_w 0.001 km/s², constant
// velocity and ±x/±y accelerations log-uniform in [0.001, 0.05] km/s², `scans` scans;
// `training` and `validation` tracks (each gives two one-axis trajectories). `extra` is appended.
inline std::filesystem::path write_ga_regime(const TempDir& dir, int scans = 50, int training = 1,
                                             int validation = 1, const std::string& extra = "") {
  const auto path = dir / "ga_regime.toml";
  write_text(
      path,
      "name = \"ga_small\"\nunits = \"km\"\nsample_period = 1.0\nscans = " + std::to_string(scans) +
          "\nprocess_noise_sigma = 0.001\n"
          "[sensor]\nkind = \"cartesian\"\nsigma = [0.5, 0.5]\n"
          "[start]\nrange = [10.0, 40.0]\nspeed = 0.015\n"
          "[[maneuvers]]\nkind = \"cv\"\nprobability = 0.5\nduration = [10.0, 30.0]\n"
          "[[maneuvers]]\nkind = \"ca\"\nprobability = 0.5\nduration = [10.0, 30.0]\n"
          "magnitude = [0.001, 0.05]\nmagnitude_scale = \"log\"\ndirection = \"axis\"\n"
          "[splits]\ntraining = " +
          std::to_string(training) + "\nvalidation = " + std::to_string(validation) +
          "\ntest = 4\nseed = 1\n" + extra);
  return path;
}

// A shipped preset (configs/regimes/paper/<name>.toml, read from the source folder the tests run
// in) with exact text replacements, written as <dir>/<name>.toml. Throws when a replacement's text
// is not in the preset, so a changed preset cannot make a test silently test something else.
inline std::filesystem::path write_preset_variant(
    const TempDir& dir, const std::string& name,
    const std::vector<std::pair<std::string, std::string>>& replacements) {
  std::ifstream in("configs/regimes/paper/" + name + ".toml");
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string text = buffer.str();
  for (const auto& [from, to] : replacements) {
    const auto at = text.find(from);
    if (at == std::string::npos) throw std::runtime_error(name + ": no '" + from + "'");
    text.replace(at, from.size(), to);
  }
  const auto path = dir / (name + ".toml");
  write_text(path, text);
  return path;
}

// `regime = "<path>"` for a trainer config.
inline std::string regime_line(const std::filesystem::path& regime) {
  return "regime = \"" + regime.string() + "\"\n";
}

}  // namespace imm::testing
