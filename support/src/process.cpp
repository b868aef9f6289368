// SPDX-License-Identifier: Apache-2.0
#include "imm/support/process.hpp"

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <stdexcept>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace imm::support {

void keep_freed_memory() {
#if defined(__GLIBC__)
  // 32 MB is the largest mapping threshold glibc takes on a 64-bit system; setting either value
  // also stops glibc from adjusting the threshold itself.
  constexpr int kHeapBelow = 32 << 20;
  constexpr int kTrimAbove = 128 << 20;
  (void)::mallopt(M_MMAP_THRESHOLD, kHeapBelow);
  (void)::mallopt(M_TRIM_THRESHOLD, kTrimAbove);
#endif
}

int run_process(const std::filesystem::path& executable, const std::vector<std::string>& arguments,
                const std::optional<std::filesystem::path>& log) {
  std::vector<std::string> storage;
  storage.push_back(executable.string());
  storage.insert(storage.end(), arguments.begin(), arguments.end());
  std::vector<char*> argv;
  argv.reserve(storage.size() + 1);
  for (auto& argument : storage) argv.push_back(argument.data());
  argv.push_back(nullptr);
  std::string out_path, err_path;
  if (log) {
    out_path = log->string() + ".out";
    err_path = log->string() + ".err";
  }
  // A bare name is looked up in PATH, a path is used as given.
  const bool search_path = storage[0].find('/') == std::string::npos;
  // fork + exec rather than posix_spawn: the child asks to be killed with its parent, so a nightly
  // killed with -9 leaves no trainer or evaluation running on behind it.
  int exec_status[2];
  if (::pipe2(exec_status, O_CLOEXEC) != 0) throw std::runtime_error("pipe2 failed");
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(exec_status[0]);
    ::close(exec_status[1]);
    throw std::runtime_error("cannot start " + storage[0] + ": fork failed");
  }
  if (pid == 0) {  // the child: async-signal-safe calls only
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);
    if (log) {
      const int out = ::open(out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
      const int err = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
      if (out < 0 || err < 0 || ::dup2(out, 1) < 0 || ::dup2(err, 2) < 0) ::_exit(127);
    }
    if (search_path) {
      ::execvp(argv[0], argv.data());
    } else {
      ::execv(argv[0], argv.data());
    }
    const int error = errno;
    (void)!::write(exec_status[1], &error, sizeof error);
    ::_exit(127);
  }
  ::close(exec_status[1]);
  int exec_error = 0;
  ssize_t got = 0;
  do {
    got = ::read(exec_status[0], &exec_error, sizeof exec_error);
  } while (got < 0 && errno == EINTR);
  ::close(exec_status[0]);
  if (got == static_cast<ssize_t>(sizeof exec_error)) {
    int ignored = 0;
    while (waitpid(pid, &ignored, 0) < 0 && errno == EINTR) {
    }
    throw std::runtime_error("cannot start " + storage[0] + ": " + std::strerror(exec_error));
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw std::runtime_error("waitpid failed for " + storage[0]);
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 1;
}

std::filesystem::path executable_folder() {
  std::error_code error;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", error);
  if (error) return std::filesystem::current_path();
  return self.parent_path();
}

}  // namespace imm::support
