// SPDX-License-Identifier: Apache-2.0
// Child processes: exit codes, signals, PATH lookup, and a tool that cannot be started; the
// process's memory policy.

#include "imm/support/process.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "testing/study.hpp"

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

// glibc gives a block of 4 MB a mapping of its own by default, and unmaps it when it is freed;
// after keep_freed_memory it comes from the heap, which keeps it once freed.
TEST(Process, FreedMemoryIsKeptForTheNextAllocations) {
#if defined(__GLIBC__)
  if (testing::running_sanitized()) GTEST_SKIP() << "the sanitizer's allocator replaces glibc's";
  keep_freed_memory();
  const struct mallinfo2 before = ::mallinfo2();
  void* block = std::malloc(std::size_t{4} << 20U);  // NOLINT(cppcoreguidelines-no-malloc)
  ASSERT_NE(block, nullptr);
  EXPECT_EQ(::mallinfo2().hblks, before.hblks);           // no mapping of its own
  std::free(block);                                       // NOLINT(cppcoreguidelines-no-malloc)
  EXPECT_GE(::mallinfo2().arena, std::size_t{4} << 20U);  // still the process's
#else
  GTEST_SKIP() << "keep_freed_memory does nothing here";
#endif
}

}  // namespace
}  // namespace imm::support
