// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/temporaries_guard.hpp"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <system_error>

namespace imm::trainer {

int remove_temporaries_of(const std::filesystem::path& folder, long pid) {
  const std::string marker = ".tmp-" + std::to_string(pid);
  int removed = 0;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(folder, error)) {
    const std::string name = entry.path().filename().string();
    const auto at = name.rfind(marker);
    if (name.empty() || name.front() != '.' || at == std::string::npos || at == 0) continue;
    const std::string rest = name.substr(at + marker.size());
    bool matches = rest.empty();
    if (rest.size() > 1 && rest.front() == '-') {
      matches = rest.find_first_not_of("0123456789", 1) == std::string::npos;
    }
    std::error_code ignored;
    if (matches && std::filesystem::remove(entry.path(), ignored)) ++removed;
  }
  return removed;
}

void guard_temporaries(const std::vector<std::filesystem::path>& folders) {
  int channel[2];
  if (::pipe2(channel, O_CLOEXEC) != 0) {
    std::fprintf(stderr, "imm-train: cannot start the temporaries guard: pipe failed\n");
    return;
  }
  const pid_t trainer = ::getpid();
  const pid_t first = ::fork();
  if (first < 0) {
    std::fprintf(stderr, "imm-train: cannot start the temporaries guard: fork failed\n");
    ::close(channel[0]);
    ::close(channel[1]);
    return;
  }
  if (first == 0) {
    // The intermediate child: fork the guard and leave, so that the guard is adopted by init and
    // the trainer has no child of its own to reap.
    if (::fork() == 0) {
      ::close(channel[1]);
      const int null = ::open("/dev/null", O_RDWR);
      if (null >= 0) {
        ::dup2(null, 0);
        ::dup2(null, 1);
        ::dup2(null, 2);
      }
      // Blocks until the trainer's end of the pipe closes: when the trainer ends, however it ends.
      char byte = 0;
      for (;;) {
        const ssize_t got = ::read(channel[0], &byte, 1);
        if (got == 0 || (got < 0 && errno != EINTR)) break;
      }
      for (const auto& folder : folders) remove_temporaries_of(folder, trainer);
      ::_exit(0);
    }
    ::_exit(0);
  }
  ::close(channel[0]);
  int status = 0;
  ::waitpid(first, &status, 0);
  // channel[1] stays open (close-on-exec) for the life of this process: its end is the signal.
}

}  // namespace imm::trainer
