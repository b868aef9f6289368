// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/provenance.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "imm/build_info.hpp"
#include "imm/io/temporary_files.hpp"

namespace imm::trainer {

io::Provenance make_provenance(std::string model_kind, std::string config_toml, std::int64_t seed,
                               std::string dataset_digest) {
  io::Provenance provenance;
  provenance.model_kind = std::move(model_kind);
  provenance.created_utc = io::utc_now();
  provenance.trainer_version = kBuildVersion;
  provenance.seed = seed;
  provenance.config_toml = std::move(config_toml);
  provenance.dataset_digest = std::move(dataset_digest);
  return provenance;
}

io::Provenance make_provenance(std::string model_kind, std::string config_toml, std::int64_t seed,
                               std::string dataset_digest, const datasets::Regime& regime) {
  io::Provenance provenance = make_provenance(std::move(model_kind), std::move(config_toml), seed,
                                              std::move(dataset_digest));
  set_regime(provenance, regime);
  return provenance;
}

nlohmann::json metrics_of(std::string_view model_kind, const std::filesystem::path& model,
                          const std::string& config) {
  nlohmann::json metrics;
  metrics["model_kind"] = model_kind;
  metrics["model"] = model.string();
  metrics["config"] = config;
  return metrics;
}

void set_regime(io::Provenance& provenance, const datasets::Regime& regime) {
  provenance.regime_name = regime.name;
  provenance.regime_toml = regime.text;
  provenance.regime_digest = regime.digest;
  provenance.length_unit = std::string(datasets::to_string(regime.units));
}

std::filesystem::path metrics_path(const std::filesystem::path& model_path) {
  return model_path.parent_path() / (model_path.stem().string() + ".metrics.json");
}

void ensure_parent_folder(const std::filesystem::path& path) {
  const auto folder = path.parent_path();
  if (!folder.empty()) create_folders_durably(folder);
}

namespace {

// A file descriptor closed on scope exit.
struct Descriptor {
  int fd = -1;
  explicit Descriptor(int d) : fd(d) {}
  Descriptor(const Descriptor&) = delete;
  Descriptor& operator=(const Descriptor&) = delete;
  ~Descriptor() {
    if (fd >= 0) ::close(fd);
  }
};

std::string errno_text() { return std::strerror(errno); }

// fsync of an open file, or a runtime_error naming it.
void sync(int fd, const std::filesystem::path& path) {
  if (::fsync(fd) != 0) throw std::runtime_error(path.string() + ": fsync: " + errno_text());
}

// The last step of every durable write: `temp` (written and fsynced) renamed over `path`, then the
// folder fsynced, so that after a power loss the folder holds the old or the new file, whole.
void rename_durably(const std::filesystem::path& temp, const std::filesystem::path& path) {
  std::error_code error;
  std::filesystem::rename(temp, path, error);
  if (error) {
    std::filesystem::remove(temp, error);
    throw std::runtime_error(path.string() + ": cannot rename its temporary into place");
  }
  std::filesystem::path folder = path.parent_path();
  if (folder.empty()) folder = ".";
  const Descriptor directory(::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (directory.fd < 0) throw std::runtime_error(folder.string() + ": open: " + errno_text());
  sync(directory.fd, folder);
}

// Removes the temporary of a write that failed (a full disk, a file-size limit), then rethrows.
template <typename Write>
void removing_temporary_on_failure(const std::filesystem::path& temp, Write&& write) {
  try {
    write();
  } catch (...) {
    std::error_code ignored;
    std::filesystem::remove(temp, ignored);
    throw;
  }
}

}  // namespace

void sync_folder(const std::filesystem::path& folder) {
  const std::filesystem::path at = folder.empty() ? std::filesystem::path(".") : folder;
  const Descriptor directory(::open(at.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (directory.fd < 0) throw std::runtime_error(at.string() + ": open: " + errno_text());
  sync(directory.fd, at);
}

void create_folders_durably(const std::filesystem::path& folder) {
  if (folder.empty() || std::filesystem::is_directory(folder)) return;
  const auto parent = folder.parent_path();
  if (!parent.empty() && parent != folder) create_folders_durably(parent);
  std::error_code error;
  if (std::filesystem::create_directory(folder, error)) {
    sync_folder(parent);
  } else if (error) {
    throw std::runtime_error(folder.string() + ": cannot create the folder: " + error.message());
  }
}

void remove_durably(const std::filesystem::path& path) {
  if (std::filesystem::remove(path)) sync_folder(path.parent_path());
}

void move_atomically(const std::filesystem::path& temp, const std::filesystem::path& path) {
  removing_temporary_on_failure(temp, [&] {
    const Descriptor file(::open(temp.c_str(), O_RDONLY | O_CLOEXEC));
    if (file.fd < 0) throw std::runtime_error(temp.string() + ": open: " + errno_text());
    sync(file.fd, temp);
  });
  rename_durably(temp, path);
}

void copy_atomically(const std::filesystem::path& from, const std::filesystem::path& to) {
  ensure_parent_folder(to);
  const auto temp = io::temporary_beside(to);
  removing_temporary_on_failure(temp, [&] {
    // read/write loops that resume after a signal (EINTR), where std::filesystem::copy_file gives
    // up on an interrupted sendfile.
    const Descriptor in(::open(from.c_str(), O_RDONLY | O_CLOEXEC));
    if (in.fd < 0) throw std::runtime_error(from.string() + ": cannot read: " + errno_text());
    const Descriptor out(::open(temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
    if (out.fd < 0) throw std::runtime_error(temp.string() + ": cannot write: " + errno_text());
    std::array<char, 1 << 16> buffer{};
    for (;;) {
      const ssize_t n = ::read(in.fd, buffer.data(), buffer.size());
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) throw std::runtime_error(from.string() + ": cannot read: " + errno_text());
      if (n == 0) break;
      std::size_t written = 0;
      while (written < static_cast<std::size_t>(n)) {
        const ssize_t w =
            ::write(out.fd, buffer.data() + written, static_cast<std::size_t>(n) - written);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) throw std::runtime_error(temp.string() + ": cannot write: " + errno_text());
        written += static_cast<std::size_t>(w);
      }
    }
    sync(out.fd, temp);
  });
  rename_durably(temp, to);
}

void write_text_atomically(const std::filesystem::path& path, const std::string& text) {
  ensure_parent_folder(path);
  const auto temp = io::temporary_beside(path);
  removing_temporary_on_failure(temp, [&] {
    const Descriptor out(::open(temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
    if (out.fd < 0) throw std::runtime_error(temp.string() + ": cannot write: " + errno_text());
    std::size_t written = 0;
    while (written < text.size()) {
      const ssize_t n = ::write(out.fd, text.data() + written, text.size() - written);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) throw std::runtime_error(temp.string() + ": cannot write: " + errno_text());
      written += static_cast<std::size_t>(n);
    }
    sync(out.fd, temp);
  });
  rename_durably(temp, path);
}

void write_json_atomically(const std::filesystem::path& path, const nlohmann::json& document) {
  write_text_atomically(path, document.dump(2) + '\n');
}

std::string read_text_file(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path.string() + ": cannot open");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

}  // namespace imm::trainer
