// SPDX-License-Identifier: Apache-2.0
// End-to-end: imm-inspect: a model file's tables and JSON.

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "testing/regime_files.hpp"
#include "testing/tools_fixture.hpp"

namespace imm {
namespace {

using testing::lines_of;
using testing::run_tool;
using testing::Tools;

TEST_F(Tools, ImmInspectPrintsTablesAndJson) {
  const auto model = dir_ / "cv3.h5";
  freeze_cv3(model);
  const auto text = run_tool("imm-inspect", {model.string()}, root_);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("kind             plain_imm"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("/imm/transition  [3x3]"), std::string::npos) << text.out;
  // Schema 2: each real attribute with its unit, read from the group's units.
  EXPECT_NE(text.out.find("/imm  mode_count=3  sample_period=1 s"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("process_noise=1e-06 km^2/s^4"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("trainer_version"), std::string::npos);
  const auto json = run_tool("imm-inspect", {model.string(), "--json"}, root_);
  ASSERT_EQ(json.exit_code, 0);
  const auto document = nlohmann::json::parse(json.out);
  EXPECT_EQ(document["kind"], "plain_imm");
  EXPECT_EQ(document["schema_version"], 2);
  EXPECT_EQ(document["objects"]["/imm/transition"]["shape"], nlohmann::json::array({3, 3}));
}

TEST_F(Tools, ImmInspectRefusesBadFilesWithOneLineAndExitCodeTwo) {
  const auto model = dir_ / "cv3.h5";
  freeze_cv3(model);
  auto bytes = testing::read_bytes(model);
  auto flipped = bytes;
  flipped[bytes.size() / 2] = static_cast<char>(flipped[bytes.size() / 2] ^ 0x10);
  testing::write_bytes(dir_ / "flipped.h5", flipped);
  testing::write_bytes(dir_ / "truncated.h5",
                       std::vector<char>(bytes.begin(), bytes.begin() + 700));
  testing::write_text(dir_ / "foreign.h5",
                      "just some text that is long enough to not be a model\n");
  for (const char* name : {"flipped.h5", "truncated.h5", "foreign.h5", "missing.h5"}) {
    const auto result = run_tool("imm-inspect", {(dir_ / name).string()}, root_);
    EXPECT_EQ(result.exit_code, 2) << name;
    EXPECT_EQ(lines_of(result.err).size(), 1u) << name << ":\n" << result.err;
    EXPECT_NE(result.err.find(name), std::string::npos) << result.err;
  }
}

TEST_F(Tools, ImmInspectShowsRuleTablesLikeTable2) {
  const auto model = dir_ / "paper.h5";
  const auto result = run_tool(
      "imm-train",
      {"import-rules", "--csv", config("configs/reference/ga_fuzzy_imm_paper_rules.csv").string(),
       "--config", config("configs/ga_fuzzy_imm.toml").string(), "--out", model.string()},
      root_);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto text = run_tool("imm-inspect", {model.string()}, root_);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("kind             ga_fuzzy_imm"), std::string::npos);
  // The column headers carry their units (schema 2: the paper's rules are in km).
  EXPECT_NE(text.out.find("c1 (km) sigma1 (km)     c2 (km) sigma2 (km) w (km^2/s^4)"),
            std::string::npos)
      << text.out;
  EXPECT_NE(text.out.find("2.33       0.376       0.254       2.591    2.15e-06"),
            std::string::npos)
      << text.out;
}

// The committed manifest prints (a tracker's metrics hold its ranking, an array, beside the
// headline metrics); a hostile one is refused on one line with exit code 2, never a crash.
TEST_F(Tools, ImmInspectPrintsTheCommittedManifestAndRefusesAHostileOne) {
  const auto shipped = run_tool("imm-inspect", {"--manifest", "models/manifest.json"}, root_);
  ASSERT_EQ(shipped.exit_code, 0) << shipped.err;
  EXPECT_NE(shipped.out.find("| agile_air | "), std::string::npos) << shipped.out.substr(0, 2000);
  EXPECT_NE(shipped.out.find("| agile_air | 'ranking' | '[{"), std::string::npos);
  const std::string deep(200000, '[');
  testing::write_text(dir_ / "manifest.json", R"({"manifest_version": 1, "models": [{"metrics": )" +
                                                  deep + std::string(200000, ']') + "}]}");
  const auto hostile =
      run_tool("imm-inspect", {"--manifest", (dir_ / "manifest.json").string()}, root_);
  EXPECT_EQ(hostile.exit_code, 2) << hostile.err;
  EXPECT_EQ(lines_of(hostile.err).size(), 1U) << hostile.err;
  EXPECT_NE(hostile.err.find("nested"), std::string::npos) << hostile.err;
}

}  // namespace
}  // namespace imm
