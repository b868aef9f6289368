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

#include "imm/io/temporary_files.hpp"

namespace imm::trainer {

int remove_temporaries_of(const std::filesystem::path& folder, long pid) {
  int removed = 0;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(folder, error)) {
    const auto writer = io::temporary_writer(entry.path().filename().string());
    if (!writer || writer->pid != pid || writer->host != io::this_host()) continue;
    std::error_code ignored;
    if (std::filesystem::remove(entry.path(), ignored)) ++removed;
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
