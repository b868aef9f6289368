// SPDX-License-Identifier: Apache-2.0
#pragma once
// The fixture of the command-line tools' end-to-end tests (tests/tools): each test runs the tools
// as separate processes, as a user would, in a temporary folder holding two tracks of seed 000's
// scenario (d.h5, plots.csv).

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "testing/run_tool.hpp"
#include "testing/temp_dir.hpp"

namespace imm::testing {

// Seed 000's scenario as a regime preset.
inline constexpr const char* kTable3 = "configs/regimes/paper/ga_imm_table3.toml";

inline std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) lines.push_back(line);
  return lines;
}

inline std::vector<std::string> fields_of(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream in(line);
  std::string field;
  while (std::getline(in, field, ',')) fields.push_back(field);
  return fields;
}

// The experiment's own tables of an imm-eval folder's metrics.json (its "results"), after checking
// the shape every experiment shares (evaluation_report.hpp).
inline nlohmann::json evaluation_results(const std::filesystem::path& out) {
  const auto metrics = nlohmann::json::parse(slurp(out / "metrics.json"));
  EXPECT_EQ(metrics.value("format", ""), "immtrain-evaluation");
  for (const char* key :
       {"experiment", "command", "regime", "runs", "seed", "models", "definitions", "results"}) {
    EXPECT_TRUE(metrics.contains(key)) << key;
  }
  EXPECT_FALSE(metrics["definitions"].empty());
  return metrics["results"];
}

class Tools : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = source_root();
    const auto result = run_tool("imm-data",
                                 {"tracks", "--regime", kTable3, "--count", "2", "--out",
                                  (dir_ / "d.h5").string(), "--csv", (dir_ / "plots.csv").string()},
                                 root_);
    ASSERT_EQ(result.exit_code, 0) << result.err;
  }

  std::filesystem::path config(const std::string& relative) const { return root_ / relative; }

  /// Freezes configs/track/cv3_imm.toml into `model` and checks that it worked.
  void freeze_cv3(const std::filesystem::path& model) const {
    const auto result =
        run_tool("imm-train",
                 {"freeze", "--config", config("configs/track/cv3_imm.toml").string(), "--out",
                  model.string()},
                 root_);
    ASSERT_EQ(result.exit_code, 0) << result.err;
  }

  /// `imm-train <command> --config <config_file> --regime <regime> --out <out>`, from the
  /// source root.
  [[nodiscard]] ToolResult train(const std::string& command,
                                 const std::filesystem::path& config_file,
                                 const std::filesystem::path& regime,
                                 const std::filesystem::path& out) const {
    return run_tool("imm-train",
                    {command, "--config", config_file.string(), "--regime", regime.string(),
                     "--out", out.string()},
                    root_);
  }

  TempDir dir_;
  std::filesystem::path root_;
};

// How many of an evaluation's headline metrics (what `imm-eval regression` compares) measure
// consistency (the position NEES log ratio), each finite and ≥ 0.
inline int consistency_headlines(const std::filesystem::path& out) {
  const auto headline = nlohmann::json::parse(slurp(out / "headline.json"));
  int count = 0;
  for (const auto& m : headline.at("metrics")) {
    if (m.at("name").get<std::string>().find("position_nees_log_ratio") == std::string::npos) {
      continue;
    }
    const double value = m.at("value");
    EXPECT_TRUE(std::isfinite(value) && value >= 0.0) << m.dump();
    ++count;
  }
  return count;
}

}  // namespace imm::testing
