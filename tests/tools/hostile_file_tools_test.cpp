// SPDX-License-Identifier: Apache-2.0
// The command-line tools on hostile model files behind valid checksums: a link cycle, a soft link
// to the root and an external link make imm-inspect (text and JSON) and imm-track refuse the file
// at once with one line naming the file and the link — never walk forever.

#include <gtest/gtest.h>

#include "testing/hdf5_edit.hpp"
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
