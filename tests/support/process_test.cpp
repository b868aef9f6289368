// SPDX-License-Identifier: Apache-2.0
// Child processes: exit codes, signals, PATH lookup, and a tool that cannot be started.

#include "imm/support/process.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

namespace imm::support {
namespace {

TEST(Process, ExitCodesAndSignalsAreReported) {
  EXPECT_EQ(run_process("/bin/sh", {"-c", "exit 0"}), 0);
  EXPECT_EQ(run_process("/bin/sh", {"-c", "exit 5"}), 5);
  EXPECT_EQ(run_process("/bin/sh", {"-c", "kill -9 $$"}), 128 + 9);
  EXPECT_EQ(run_process("sh", {"-c", "exit 3"}), 3);  // looked up in PATH
  EXPECT_THROW((void)run_process("/no/such/tool", {}), std::runtime_error);
}

TEST(Process, LogGoesToItsTwoFiles) {
  const auto stem = std::filesystem::temp_directory_path() / "immtrain-process-test";
  ASSERT_EQ(run_process("/bin/sh", {"-c", "echo out; echo err >&2"}, stem), 0);
  std::ifstream out(stem.string() + ".out"), err(stem.string() + ".err");
  std::string out_line, err_line;
  std::getline(out, out_line);
  std::getline(err, err_line);
  EXPECT_EQ(out_line, "out");
  EXPECT_EQ(err_line, "err");
  std::filesystem::remove(stem.string() + ".out");
  std::filesystem::remove(stem.string() + ".err");
}

TEST(Process, ExecutableFolderHoldsThisTest) {
  EXPECT_TRUE(std::filesystem::exists(executable_folder() / "support_process_test"));
}

}  // namespace
}  // namespace imm::support
