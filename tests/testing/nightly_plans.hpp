// SPDX-License-Identifier: Apache-2.0
#pragma once
// The nightly's tests' small plans (tests/tools/nightly_test.cpp, nightly_stages_test.cpp): the
// plain IMM of configs/track/cv3_imm.toml as the one model, a temporary registry, and the tools
// with planted faults.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "testing/run_tool.hpp"
#include "testing/temp_dir.hpp"

namespace imm::testing {

namespace fs = std::filesystem;

inline std::string sha256_of(const fs::path& file) {
  const auto result = run_tool("/usr/bin/sha256sum", {file.string()}, {});
  return result.out.substr(0, 64);
}

// The plain IMM of configs/track/cv3_imm.toml with its three noise levels scaled by `scale`.
inline void write_cv3(const fs::path& path, double scale, const std::string& comment = "") {
  std::string text = slurp("configs/track/cv3_imm.toml");
  for (const char* level : {"1e-6", "1e-4", "1e-2"}) {
    const std::string from = std::string("process_noise = ") + level;
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos);
    text.replace(at, from.size(), "process_noise = " + std::to_string(std::stod(level) * scale));
  }
  std::ofstream(path) << comment << text;
}

struct Plan {
  fs::path dir, registry, plan, reports;
};

// The tests' plans allow a trainer built from uncommitted code (a developer's build tree); the
// refusal is tested on its own below.
inline Plan write_plan(const TempDir& dir, const std::string& extra_models = "",
                       bool allow_dirty_trainer = true) {
  Plan p{dir.path(), dir / "models", dir / "nightly.toml", dir / "nightly"};
  std::ofstream(p.plan) << "registry = \"" << p.registry.string() << "\"\n"
                        << "evaluations_page = \"" << (dir / "docs" / "evaluations.md").string()
                        << "\"\n"
                        << "allow_dirty_trainer = " << (allow_dirty_trainer ? "true" : "false")
                        << "\n[regression]\nrelative_margin = 0.001\n"
                        << "reason = \"rounding across machines\"\n"
                        << extra_models
                        << "[[models]]\nname = \"cv3\"\ncommand = \"freeze\"\nconfig = \""
                        << (dir / "cv3.toml").string() << "\"\n"
                        << "out = \"" << (p.registry / "cv3.h5").string() << "\"\n\n"
                        << "[[evaluations]]\nexperiment = \"plain-imm\"\nmodel = \"cv3\"\nout = \""
                        << (dir / "reports" / "cv3").string()
                        << "\"\nregime = \"configs/regimes/paper/ga_imm_table3.toml\"\nruns = 40\n";
  return p;
}

inline ToolResult nightly(const Plan& p, std::vector<std::string> extra = {}) {
  std::vector<std::string> arguments = {"all", "--config", p.plan.string(), "--reports",
                                        p.reports.string()};
  arguments.insert(arguments.end(), extra.begin(), extra.end());
  return run_tool("imm-train", arguments, {}, 300);
}

inline nlohmann::json manifest(const Plan& p) {
  return nlohmann::json::parse(slurp(p.registry / "manifest.json"));
}

// The cv3 plan (write_plan) after its first night, which ships cv3.h5 into its registry.
struct FirstNight {
  Plan plan;
  ToolResult night;  // exit code 0 when the model was shipped
  fs::path shipped;  // the shipped file
};
inline FirstNight first_night(const TempDir& dir) {
  write_cv3(dir / "cv3.toml", 1.0);
  FirstNight f{write_plan(dir), {}, {}};
  f.night = nightly(f.plan);
  f.shipped = f.plan.registry / "cv3.h5";
  return f;
}

// The nightly's tools with planted faults: the night runs as <bin>/imm-train-night, a copy of
// imm-train (so its tool folder is <bin>), and the tools it starts, <bin>/imm-train and
// <bin>/imm-eval, are scripts that run their `before` lines and then the real tool.
class PlantedTools {
 public:
  explicit PlantedTools(fs::path bin) : bin_(std::move(bin)) {
    fs::create_directories(bin_);
    fs::copy_file(tool_path("imm-train"), bin_ / "imm-train-night");
    plant("imm-train", "");
    plant("imm-eval", "");
  }
  // Rewrites <bin>/<name> to run the shell lines `before` first.
  void plant(const std::string& name, const std::string& before) const {
    std::ofstream(bin_ / name) << "#!/bin/sh\n"
                               << before << "exec " << fs::absolute(tool_path(name)).string()
                               << " \"$@\"\n";
    fs::permissions(bin_ / name, fs::perms::owner_all);
  }
  // Rewrites <bin>/<name> to run the real tool and then the shell lines `after` (the tool's exit
  // code is in $code).
  void plant_after(const std::string& name, const std::string& after) const {
    std::ofstream(bin_ / name) << "#!/bin/sh\n"
                               << fs::absolute(tool_path(name)).string() << " \"$@\"\n"
                               << "code=$?\n"
                               << after << "exit $code\n";
    fs::permissions(bin_ / name, fs::perms::owner_all);
  }
  [[nodiscard]] ToolResult night(const Plan& p) const {
    return run_tool((bin_ / "imm-train-night").string(),
                    {"all", "--config", p.plan.string(), "--reports", p.reports.string()}, {}, 300);
  }

 private:
  fs::path bin_;
};

}  // namespace imm::testing
