// SPDX-License-Identifier: Apache-2.0
#include "imm/io/temporary_files.hpp"

#include <signal.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <charconv>

namespace imm::io {

const std::string& this_host() {
  static const std::string host = [] {
    std::array<char, 256> buffer{};
    if (::gethostname(buffer.data(), buffer.size() - 1) != 0 || buffer[0] == '\0') {
      return std::string("localhost");
    }
    std::string name(buffer.data());
    for (char& c : name) {
      const bool allowed = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                           (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
      if (!allowed) c = '_';
    }
    return name;
  }();
  return host;
}

std::filesystem::path temporary_beside(const std::filesystem::path& target,
                                       std::optional<unsigned> counter) {
  std::string name = ".";
  name += target.filename().string();
  name += ".tmp-";
  name += std::to_string(::getpid());
  if (counter) {
    name += '-';
    name += std::to_string(*counter);
  }
  name += '@';
  name += this_host();
  return target.parent_path() / name;
}

namespace {

// "<pid>" or "<pid>-<n>": the process ID.
std::optional<long> process_of(std::string_view text) {
  const char* end = text.data() + text.size();
  long pid = 0;
  auto [next, error] = std::from_chars(text.data(), end, pid);
  if (error != std::errc() || next == text.data() || pid <= 0) return std::nullopt;
  if (next != end) {
    if (*next != '-') return std::nullopt;
    unsigned counter = 0;
    const char* digits = next + 1;
    auto [after, counter_error] = std::from_chars(digits, end, counter);
    if (counter_error != std::errc() || after == digits || after != end) return std::nullopt;
  }
  return pid;
}

// ".<name>.tmp-<pid>[-<n>]" (`head`): the process ID.
std::optional<long> process_of_head(std::string_view head) {
  const auto marker = head.rfind(".tmp-");
  if (head.empty() || head.front() != '.' || marker == std::string_view::npos || marker == 0) {
    return std::nullopt;
  }
  return process_of(head.substr(marker + 5));
}

}  // namespace

std::optional<TemporaryWriter> temporary_writer(std::string_view file_name) {
  // ".<name>.tmp-<pid>[-<n>]@<host>" (the host is the part after the last '@').
  if (const auto at = file_name.rfind('@');
      at != std::string_view::npos && at + 1 < file_name.size()) {
    if (const auto pid = process_of_head(file_name.substr(0, at))) {
      return TemporaryWriter{*pid, std::string(file_name.substr(at + 1))};
    }
  }
  // ".<name>.tmp-<pid>[-<n>]", written before temporaries carried their host.
  if (const auto pid = process_of_head(file_name)) return TemporaryWriter{*pid, this_host()};
  return std::nullopt;
}

bool is_stale_temporary(std::string_view file_name) {
  const auto writer = temporary_writer(file_name);
  if (!writer || writer->host != this_host()) return false;
  return ::kill(static_cast<pid_t>(writer->pid), 0) != 0 && errno == ESRCH;
}

}  // namespace imm::io
