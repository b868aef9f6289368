// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Runs one of the project's executables (from $IMM_BIN_DIR, set by ctest) and captures its exit
/// code, standard output and standard error — for end-to-end tests of the command-line tools.

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace imm::testing {

struct ToolResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

inline std::filesystem::path tool_path(const std::string& name) {
  const char* dir = std::getenv("IMM_BIN_DIR");
  return std::filesystem::path(dir != nullptr ? dir : "build/bin") / name;
}

inline std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

/// A fresh file name under the temp folder (tests run in parallel: no shared names).
inline std::filesystem::path unique_temp_file(const char* stem) {
  std::string pattern =
      (std::filesystem::temp_directory_path() / (std::string(stem) + "-XXXXXX")).string();
  const int fd = ::mkstemp(pattern.data());
  if (fd >= 0) ::close(fd);
  return pattern;
}

/// Starts `tool` with stdout and stderr going to the given files (in `working_directory` when
/// given); returns its pid, or -1.
inline pid_t start_tool(const std::string& tool, const std::vector<std::string>& arguments,
                        const std::string& out_file, const std::string& err_file,
                        const std::filesystem::path& working_directory = {}) {
  std::vector<std::string> storage{tool_path(tool).string()};
  storage.insert(storage.end(), arguments.begin(), arguments.end());
  std::vector<char*> argv;
  argv.reserve(storage.size() + 1);
  for (auto& a : storage) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
  posix_spawn_file_actions_addopen(&actions, 2, err_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 29))
  if (!working_directory.empty()) {
    posix_spawn_file_actions_addchdir_np(&actions, working_directory.c_str());
  }
#endif
  pid_t pid = -1;
  if (posix_spawn(&pid, storage[0].c_str(), &actions, nullptr, argv.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&actions);
  return pid;
}

/// Exit code run_tool reports for a tool it killed at its time limit.
inline constexpr int kTimedOut = -2;

/// Runs `tool` with `arguments` in `working_directory` and waits for it; with a positive
/// `timeout_seconds` the tool is killed at that limit and the exit code is kTimedOut. A tool
/// killed by a signal reports 128 + the signal number.
inline ToolResult run_tool(const std::string& tool, const std::vector<std::string>& arguments,
                           const std::filesystem::path& working_directory,
                           double timeout_seconds = 0.0) {
  const auto out_file = unique_temp_file("immtrain-tool-stdout");
  const auto err_file = unique_temp_file("immtrain-tool-stderr");
  ToolResult result;
  const pid_t pid = start_tool(tool, arguments, out_file, err_file, working_directory);
  if (pid > 0) {
    int status = 0;
    if (timeout_seconds > 0.0) {
      const auto deadline =
          std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_seconds);
      while (waitpid(pid, &status, WNOHANG) == 0) {
        if (std::chrono::steady_clock::now() > deadline) {
          kill(pid, SIGKILL);
          waitpid(pid, &status, 0);
          status = -1;
          break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
      }
    } else {
      waitpid(pid, &status, 0);
    }
    result.exit_code = status == -1        ? kTimedOut
                       : WIFEXITED(status) ? WEXITSTATUS(status)
                                           : 128 + WTERMSIG(status);
  }
  result.out = slurp(out_file);
  result.err = slurp(err_file);
  std::filesystem::remove(out_file);
  std::filesystem::remove(err_file);
  return result;
}

/// Starts `tool` without waiting (output discarded); returns its pid, or -1.
inline pid_t spawn_tool(const std::string& tool, const std::vector<std::string>& arguments) {
  return start_tool(tool, arguments, "/dev/null", "/dev/null");
}

/// The repository root (ctest runs the tests there).
inline std::filesystem::path source_root() { return std::filesystem::current_path(); }

}  // namespace imm::testing
