// SPDX-License-Identifier: Apache-2.0
// End-to-end: imm-data: seeded track splits and sensor samples.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "testing/regime_files.hpp"
#include "testing/tools_fixture.hpp"

namespace imm {
namespace {

using testing::kTable3;
using testing::run_tool;
using testing::Tools;

TEST_F(Tools, ImmDataIsReproducibleForASeed) {
  const auto again = run_tool(
      "imm-data",
      {"tracks", "--regime", kTable3, "--count", "2", "--out", (dir_ / "e.h5").string()}, root_);
  const auto other = run_tool("imm-data",
                              {"tracks", "--regime", kTable3, "--count", "2", "--seed", "9",
                               "--out", (dir_ / "f.h5").string()},
                              root_);
  ASSERT_EQ(again.exit_code, 0);
  const auto inspect_d = run_tool("imm-inspect", {(dir_ / "d.h5").string(), "--json"}, root_);
  const auto inspect_e = run_tool("imm-inspect", {(dir_ / "e.h5").string(), "--json"}, root_);
  const auto inspect_f = run_tool("imm-inspect", {(dir_ / "f.h5").string(), "--json"}, root_);
  const auto digest = [](const testing::ToolResult& r) {
    return nlohmann::json::parse(r.out)["attributes"]["digest"].get<std::string>();
  };
  EXPECT_EQ(digest(inspect_d), digest(inspect_e));
  EXPECT_NE(digest(inspect_d), digest(inspect_f));
}

TEST_F(Tools, ImmDataWritesSensorSamplesAndTrackSplits) {
  const std::string regime = "configs/regimes/paper/fimm_table1.toml";
  const auto sensor = run_tool(
      "imm-data", {"sensor", "--regime", regime, "--out", (dir_ / "r.h5").string()}, root_);
  ASSERT_EQ(sensor.exit_code, 0) << sensor.err;
  const auto again = run_tool(
      "imm-data", {"sensor", "--regime", regime, "--out", (dir_ / "r2.h5").string()}, root_);
  ASSERT_EQ(again.exit_code, 0) << again.err;
  const auto a = nlohmann::json::parse(
      run_tool("imm-inspect", {(dir_ / "r.h5").string(), "--json"}, root_).out);
  const auto b = nlohmann::json::parse(
      run_tool("imm-inspect", {(dir_ / "r2.h5").string(), "--json"}, root_).out);
  EXPECT_EQ(a["kind"], "range_sensor");
  EXPECT_TRUE(a["validated"].get<bool>());
  EXPECT_EQ(a["attributes"]["digest"], b["attributes"]["digest"]);  // same regime and seed

  const auto cut_in = run_tool(
      "imm-data", {"tracks", "--regime", regime, "--count", "4", "--out", (dir_ / "c.h5").string()},
      root_);
  ASSERT_EQ(cut_in.exit_code, 0) << cut_in.err;
  EXPECT_NE(cut_in.out.find("4 tracks"), std::string::npos) << cut_in.out;
  const auto training = run_tool(
      "imm-data",
      {"tracks", "--regime", regime, "--split", "training", "--out", (dir_ / "t.h5").string()},
      root_);
  ASSERT_EQ(training.exit_code, 0) << training.err;
  EXPECT_NE(training.out.find("training split, 8 tracks"), std::string::npos) << training.out;
  // A regime without a range sensor has no sensor samples.
  const auto bad = run_tool(
      "imm-data", {"sensor", "--regime", kTable3, "--out", (dir_ / "bad.h5").string()}, root_);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("sensor.kind"), std::string::npos) << bad.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "bad.h5"));
}

// Scenes: a regime's [scene] by default, every plot with its origin, every target's truth at
// every scan; the same seed writes the same files, and the options override the regime.
TEST_F(Tools, ImmDataWritesScenesOfSeveralTargetsAmongClutter) {
  auto regime_text = testing::slurp(root_ / "configs/regimes/agile_air.toml");
  regime_text += "\n[scene]\ntargets = 2\ndetection_probability = 1.0\nclutter_per_scan = 0.0\n";
  testing::write_text(dir_ / "scene_regime.toml", regime_text);
  const auto scenes = [&](const std::string& out, std::vector<std::string> extra) {
    std::vector<std::string> arguments = {
        "scenes",    "--regime",           (dir_ / "scene_regime.toml").string(), "--count", "2",
        "--out-dir", (dir_ / out).string()};
    arguments.insert(arguments.end(), extra.begin(), extra.end());
    return run_tool("imm-data", arguments, root_);
  };
  const auto clean = scenes("clean", {});
  ASSERT_EQ(clean.exit_code, 0) << clean.err;
  const auto plots = testing::lines_of(testing::slurp(dir_ / "clean/scene_001.csv"));
  const auto truth = testing::lines_of(testing::slurp(dir_ / "clean/scene_001_truth.csv"));
  EXPECT_EQ(plots.front(), "k,t,zx,zy,origin");
  EXPECT_EQ(truth.front(), "k,t,target,x,vx,y,vy");
  // Every target detected, no clutter: one plot per target and scan, as many as truth rows.
  EXPECT_EQ(plots.size(), truth.size());
  for (std::size_t i = 1; i < plots.size(); ++i) {
    EXPECT_TRUE(plots[i].ends_with(",0") || plots[i].ends_with(",1")) << plots[i];
  }
  const auto cluttered = scenes("cluttered", {"--pd", "0.5", "--clutter", "4", "--targets", "3"});
  const auto again = scenes("again", {"--pd", "0.5", "--clutter", "4", "--targets", "3"});
  ASSERT_EQ(cluttered.exit_code, 0) << cluttered.err;
  EXPECT_EQ(testing::slurp(dir_ / "cluttered/scene_000.csv"),
            testing::slurp(dir_ / "again/scene_000.csv"));
  const auto noisy = testing::lines_of(testing::slurp(dir_ / "cluttered/scene_000.csv"));
  std::size_t false_plots = 0;
  for (const auto& line : noisy) false_plots += line.ends_with(",-1") ? 1 : 0;
  EXPECT_GT(false_plots, 0U);
  EXPECT_NE(cluttered.out.find("3 targets, Pd 0.5, 4 false plots per scan"), std::string::npos)
      << cluttered.out;
  const auto refused = scenes("refused", {"--pd", "0"});
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("scene.detection_probability"), std::string::npos) << refused.err;
  // A count beyond what a split may hold is refused, naming the option, before any file is written.
  const auto too_many = run_tool("imm-data",
                                 {"scenes", "--regime", (dir_ / "scene_regime.toml").string(),
                                  "--count", "1000001", "--out-dir", (dir_ / "too_many").string()},
                                 root_);
  EXPECT_EQ(too_many.exit_code, 1);
  EXPECT_NE(too_many.err.find("--count: must be in [1, 1000000] (got 1000001)"), std::string::npos)
      << too_many.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "too_many"));
}

}  // namespace
}  // namespace imm
