// SPDX-License-Identifier: Apache-2.0
// End-to-end: imm-data: seeded track splits and sensor samples.

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace imm
