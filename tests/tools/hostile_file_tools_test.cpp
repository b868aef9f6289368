// SPDX-License-Identifier: Apache-2.0
// The command-line tools on hostile model files behind valid checksums: a link cycle, a soft link
// to the root and an external link make imm-inspect (text and JSON) and imm-track refuse the file
// at once with one line naming the file and the link — never walk forever.

#include <gtest/gtest.h>

#include "testing/hdf5_edit.hpp"
#include "testing/hostile_hdf5.hpp"
#include "testing/run_tool.hpp"
#include "testing/temp_dir.hpp"

namespace imm {
namespace {

struct LinkDrill {
  std::string name;
  std::function<void(hid_t)> edit;
  std::string field;
};

void PrintTo(const LinkDrill& drill, std::ostream* out) { *out << drill.name; }

class HostileFileTools : public ::testing::TestWithParam<LinkDrill> {};

TEST_P(HostileFileTools, ImmInspectAndImmTrackRefuseTheFileAtOnce) {
  const LinkDrill& drill = GetParam();
  const testing::TempDir dir;
  const auto path = dir / "hostile.h5";
  testing::write_bytes(path, testing::read_bytes("models/cv3_imm.h5"));
  testing::edit_and_reseal(path, drill.edit);
  const auto root = testing::source_root();
  const std::vector<std::vector<std::string>> commands = {
      {"imm-inspect", path.string()},
      {"imm-inspect", path.string(), "--json"},
      {"imm-track", "--filter", path.string(), "--measurements", "/dev/null"}};
  for (const auto& command : commands) {
    const auto result = testing::run_tool(
        command[0], std::vector<std::string>(command.begin() + 1, command.end()), root, 10.0);
    ASSERT_NE(result.exit_code, testing::kTimedOut) << command[0] << " hangs";
    EXPECT_EQ(result.exit_code, 2) << command[0] << ": " << result.err;
    EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
    EXPECT_NE(result.err.find(path.string() + ": field '" + drill.field + "'"), std::string::npos)
        << result.err;
    EXPECT_TRUE(result.out.empty()) << result.out;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Links, HostileFileTools,
    ::testing::Values(
        LinkDrill{
            "hard_link_to_the_root",
            [](hid_t f) { H5Lcreate_hard(f, "/", f, "/imm/modes/loop", H5P_DEFAULT, H5P_DEFAULT); },
            "/imm/modes/loop"},
        LinkDrill{"hard_link_to_the_parent",
                  [](hid_t f) {
                    H5Lcreate_hard(f, "/imm", f, "/imm/modes/up", H5P_DEFAULT, H5P_DEFAULT);
                  },
                  "/imm/modes/up"},
        LinkDrill{"soft_link_to_the_root",
                  [](hid_t f) { H5Lcreate_soft("/", f, "/imm/loop", H5P_DEFAULT, H5P_DEFAULT); },
                  "/imm/loop"},
        LinkDrill{"external_link",
                  [](hid_t f) {
                    H5Lcreate_external("/etc/hostname", "/", f, "/ext", H5P_DEFAULT, H5P_DEFAULT);
                  },
                  "/ext"}),
    [](const ::testing::TestParamInfo<LinkDrill>& param) { return param.param.name; });

}  // namespace
}  // namespace imm

namespace imm {
namespace {

// An edit made with HDF5 directly (as h5py would) breaks the checksum: --verify says so and
// names `imm-train seal`; sealing checks the content first, so a valid edit is re-sealed and an
// invalid one is refused naming the field, with the file left byte for byte as it was.
TEST(SealAndVerify, AnEditedModelIsReSealedOnlyWhenItStillReads) {
  const testing::TempDir dir;
  const auto path = dir / "edited.h5";
  testing::write_bytes(path, testing::read_bytes("models/cv3_imm.h5"));
  const auto root = testing::source_root();
  const auto verify = [&] {
    return testing::run_tool("imm-inspect", {path.string(), "--verify"}, root);
  };
  const auto intact = verify();
  EXPECT_EQ(intact.exit_code, 0) << intact.err;
  EXPECT_NE(intact.out.find(": ok (immtrain-model, schema 2, plain_imm"), std::string::npos)
      << intact.out;

  const auto edit = [&](const std::vector<double>& covariance) {
    const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    testing::replace_dataset(file, "/measurement/covariance", {2, 2}, covariance);
    H5Fclose(file);
  };
  edit({0.3, 0.0, 0.0, 0.3});  // a deliberate, valid change of R
  const auto broken = verify();
  EXPECT_EQ(broken.exit_code, 2);
  EXPECT_NE(broken.err.find("payload checksum mismatch"), std::string::npos) << broken.err;
  EXPECT_NE(broken.err.find("imm-train seal " + path.string()), std::string::npos) << broken.err;
  EXPECT_EQ(std::count(broken.err.begin(), broken.err.end(), '\n'), 1) << broken.err;

  const auto sealed = testing::run_tool("imm-train", {"seal", path.string()}, root);
  EXPECT_EQ(sealed.exit_code, 0) << sealed.err;
  EXPECT_NE(sealed.err.find("sealed " + path.string() + " (plain_imm"), std::string::npos)
      << sealed.err;
  EXPECT_EQ(verify().exit_code, 0);
  const auto track = testing::run_tool("imm-inspect", {path.string()}, root);
  EXPECT_NE(track.out.find("0.3"), std::string::npos) << track.out;

  edit({0.3, 0.0, 0.0, -1.0});  // R no longer positive definite
  const std::vector<char> before = testing::read_bytes(path);
  const auto refused = testing::run_tool("imm-train", {"seal", path.string()}, root);
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find(path.string() + ": field '/measurement/covariance'"),
            std::string::npos)
      << refused.err;
  EXPECT_EQ(testing::read_bytes(path), before);  // unchanged, still unsealed
  EXPECT_EQ(verify().exit_code, 2);
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos) << entry.path();
  }
}

// `--verify` is what a person runs before shipping a file by hand: on a sample of the hostile
// mutants of two shipped models (every 16th of the drill's mutations, resealed) it prints exactly
// one line — "ok" on stdout for a file that reads whole, or the refusal naming the file on stderr
// (no HDF5 error stack or shutdown noise after it) — and never says "ok" about a file the runtime
// refuses.
TEST(SealAndVerify, VerifySaysOneLineAboutEveryHostileMutant) {
  const testing::TempDir dir;
  const auto root = testing::source_root();
  std::size_t sampled = 0;
  for (const char* model : {"models/ga_fuzzy_imm_agile_air.h5", "models/mlp_input_estimator.h5"}) {
    const auto bytes = testing::read_bytes(model);
    const auto mutations = testing::mutations_of(testing::layout_of(model));
    for (std::size_t i = 0; i < mutations.size(); i += 16, ++sampled) {
      SCOPED_TRACE(std::string(model) + ": " + mutations[i].name);
      const auto path = dir / "mutant.h5";
      testing::write_bytes(path, bytes);
      testing::edit_and_reseal(path, mutations[i].apply);
      const auto verify = testing::run_tool("imm-inspect", {path.string(), "--verify"}, root, 10.0);
      ASSERT_NE(verify.exit_code, testing::kTimedOut);
      if (verify.exit_code == 0) {
        EXPECT_TRUE(verify.err.empty()) << verify.err;
        EXPECT_EQ(std::count(verify.out.begin(), verify.out.end(), '\n'), 1) << verify.out;
        EXPECT_FALSE(mutations[i].structural) << "ok about a structurally hostile file";
      } else {
        EXPECT_EQ(verify.exit_code, 2) << verify.err;
        EXPECT_EQ(std::count(verify.err.begin(), verify.err.end(), '\n'), 1) << verify.err;
        EXPECT_EQ(verify.err.find("imm-inspect: " + path.string() + ": "), 0u) << verify.err;
        EXPECT_TRUE(verify.out.empty()) << verify.out;
      }
    }
  }
  EXPECT_GT(sampled, 20u);
}

}  // namespace
}  // namespace imm
