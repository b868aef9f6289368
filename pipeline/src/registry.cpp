// SPDX-License-Identifier: Apache-2.0
#include "imm/pipeline/registry.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "imm/datasets/sha256.hpp"
#include "imm/io/model_file.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::pipeline {
namespace {

constexpr int kManifestVersion = 1;

nlohmann::json to_json(const RegistryEntry& e) {
  nlohmann::json j = {{"name", e.name},
                      {"kind", e.kind},
                      {"regime", {{"name", e.regime_name}, {"digest", e.regime_digest}}},
                      {"file", e.file},
                      {"sha256", e.sha256},
                      {"schema_version", e.schema_version},
                      {"trainer_version", e.trainer_version},
                      {"config_digest", e.config_digest},
                      {"trained_utc", e.trained_utc},
                      {"inputs_digest", e.inputs_digest},
                      {"promoted_utc", e.promoted_utc},
                      {"metrics", e.metrics}};
  if (!e.promotion_reason.empty()) j["promotion_reason"] = e.promotion_reason;
  if (!e.history.empty()) {
    j["history"] = nlohmann::json::array();
    for (const RegistryEntry& h : e.history) j["history"].push_back(to_json(h));
  }
  return j;
}

RegistryEntry from_json(const nlohmann::json& j, const std::string& where) {
  try {
    RegistryEntry e;
    e.name = j.at("name").get<std::string>();
    e.kind = j.at("kind").get<std::string>();
    e.regime_name = j.at("regime").at("name").get<std::string>();
    e.regime_digest = j.at("regime").at("digest").get<std::string>();
    e.file = j.at("file").get<std::string>();
    e.sha256 = j.at("sha256").get<std::string>();
    e.schema_version = j.at("schema_version").get<int>();
    e.trainer_version = j.at("trainer_version").get<std::string>();
    e.config_digest = j.at("config_digest").get<std::string>();
    e.trained_utc = j.at("trained_utc").get<std::string>();
    e.inputs_digest = j.value("inputs_digest", "");
    e.promoted_utc = j.value("promoted_utc", "");
    e.metrics = j.value("metrics", nlohmann::json::object());
    e.promotion_reason = j.value("promotion_reason", "");
    if (j.contains("history")) {
      for (const auto& h : j.at("history")) e.history.push_back(from_json(h, where + ".history"));
    }
    const std::filesystem::path file(e.file);
    if (e.file.empty() || file.is_absolute() ||
        std::any_of(file.begin(), file.end(), [](const auto& part) { return part == ".."; })) {
      throw std::runtime_error("file '" + e.file + "' must be a path inside the models folder");
    }
    if (const std::string problem = model_name_problem(e.name); !problem.empty()) {
      throw std::runtime_error("name: " + problem);
    }
    if (const std::string problem = sha256_problem(e.sha256); !problem.empty()) {
      throw std::runtime_error("sha256: " + problem);
    }
    return e;
  } catch (const nlohmann::json::exception& error) {
    throw std::runtime_error(where + ": " + error.what());
  } catch (const std::runtime_error& error) {
    throw std::runtime_error(where + ": " + error.what());
  }
}

using trainer::copy_atomically;

// The registry's one lock (`<models>/.registry/lock`, flock): every change of the manifest holds
// it from reading the manifest to writing it, so two commands (a nightly's promotion, a rollback
// or a promotion by hand) never write from a stale copy. The lock dies with its process.
class RegistryLock {
 public:
  explicit RegistryLock(const std::filesystem::path& folder) {
    const auto path = folder / ".registry" / "lock";
    std::filesystem::create_directories(path.parent_path());
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) {
      throw std::runtime_error(path.string() +
                               ": cannot open the registry's lock: " + std::strerror(errno));
    }
    while (::flock(fd_, LOCK_EX) != 0) {
      if (errno == EINTR) continue;
      const std::string why = std::strerror(errno);
      ::close(fd_);
      throw std::runtime_error(path.string() + ": cannot lock the registry: " + why);
    }
  }
  RegistryLock(const RegistryLock&) = delete;
  RegistryLock& operator=(const RegistryLock&) = delete;
  ~RegistryLock() { ::close(fd_); }

 private:
  int fd_ = -1;
};

std::filesystem::path metrics_beside(const std::filesystem::path& model) {
  return trainer::metrics_path(model);
}

}  // namespace

bool from_uncommitted_code(const RegistryEntry& entry) {
  return entry.trainer_version.ends_with("-dirty");
}

std::string model_name_problem(std::string_view name) {
  std::string quoted(1, '\'');
  quoted.append(name).push_back('\'');
  if (name.empty() || name.size() > 128) return quoted + " must have 1 to 128 characters";
  if (name.front() == '.') return quoted + " must not start with '.'";
  for (const char c : name) {
    const bool allowed = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                         (c >= '0' && c <= '9') || c == '_' || c == '-' || c == '.';
    if (!allowed) {
      return quoted + " must be one path component of letters, digits, '_', '-' and '.'";
    }
  }
  return "";
}

std::string sha256_problem(std::string_view digest) {
  const bool hex = std::all_of(digest.begin(), digest.end(), [](char c) {
    return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f');
  });
  if (digest.size() != 64 || !hex) return "is not a SHA-256 digest (64 lowercase hex digits)";
  return "";
}

RegistryEntry describe_model(const std::filesystem::path& file,
                             const std::filesystem::path& models_folder, const std::string& name) {
  const io::ModelFileReader reader(file);
  const io::Provenance& p = reader.provenance();
  RegistryEntry e;
  e.name = name;
  e.kind = p.model_kind;
  e.regime_name = p.regime_name;
  e.regime_digest = p.regime_digest;
  e.sha256 = datasets::file_sha256_hex(file);
  e.schema_version = reader.schema_version();
  e.trainer_version = p.trainer_version;
  e.config_digest = datasets::sha256_hex(p.config_toml);
  e.trained_utc = p.created_utc;
  e.file = std::filesystem::relative(file, models_folder).generic_string();
  return e;
}

Registry::Registry(std::filesystem::path models_folder) : folder_(std::move(models_folder)) {
  load();
}

std::filesystem::path Registry::staging_folder() const { return folder_ / ".registry" / "staging"; }

std::filesystem::path Registry::archive_path(const std::string& sha256) const {
  return folder_ / ".registry" / "archive" / (sha256 + ".h5");
}

const RegistryEntry* Registry::find(const std::string& name) const {
  for (const RegistryEntry& e : entries_) {
    if (e.name == name) return &e;
  }
  return nullptr;
}

std::vector<const RegistryEntry*> Registry::find(const std::string& kind,
                                                 const std::string& regime) const {
  std::vector<const RegistryEntry*> found;
  for (const RegistryEntry& e : entries_) {
    if ((e.kind == kind || e.name.rfind(kind, 0) == 0) && e.regime_name == regime) {
      found.push_back(&e);
    }
  }
  return found;
}

void Registry::load() {
  entries_.clear();
  const auto path = manifest_path();
  if (!std::filesystem::exists(path)) return;
  nlohmann::json document;
  try {
    document = nlohmann::json::parse(trainer::read_text_file(path));
  } catch (const nlohmann::json::exception& error) {
    throw std::runtime_error(path.string() + ": not JSON (" + error.what() + ")");
  }
  if (!document.is_object() || document.value("manifest_version", 0) != kManifestVersion ||
      !document.contains("models") || !document.at("models").is_array()) {
    throw std::runtime_error(path.string() + ": manifest_version: expected " +
                             std::to_string(kManifestVersion) + " with a 'models' array");
  }
  for (std::size_t i = 0; i < document.at("models").size(); ++i) {
    entries_.push_back(
        from_json(document.at("models")[i], path.string() + ": models[" + std::to_string(i) + "]"));
    if (std::count_if(entries_.begin(), entries_.end(),
                      [&](const RegistryEntry& e) { return e.name == entries_.back().name; }) > 1) {
      throw std::runtime_error(path.string() + ": models[" + std::to_string(i) + "].name '" +
                               entries_.back().name + "' appears twice");
    }
  }
}

void Registry::commit(std::vector<RegistryEntry> entries) {
  nlohmann::json document = {{"manifest_version", kManifestVersion},
                             {"models", nlohmann::json::array()}};
  for (const RegistryEntry& e : entries) document["models"].push_back(to_json(e));
  trainer::write_json_atomically(manifest_path(), document);
  entries_ = std::move(entries);
}

void Registry::archive(const std::filesystem::path& file, const std::string& sha256) const {
  const auto target = archive_path(sha256);
  if (std::filesystem::exists(target) && datasets::file_sha256_hex(target) == sha256) return;
  copy_atomically(file, target);
}

void Registry::materialize(const RegistryEntry& entry) const {
  const auto target = folder_ / entry.file;
  if (std::filesystem::exists(target) && datasets::file_sha256_hex(target) == entry.sha256) return;
  const auto source = archive_path(entry.sha256);
  if (!std::filesystem::exists(source)) {
    throw std::runtime_error(target.string() + ": differs from the manifest's sha256 " +
                             entry.sha256.substr(0, 12) + " and the archive has no copy");
  }
  // What is shipped is checked first: a damaged archive copy (a write cut short) is never
  // "restored" into models/.
  if (datasets::file_sha256_hex(source) != entry.sha256) {
    throw std::runtime_error(source.string() + ": the archive copy of " + entry.file +
                             " does not match its sha256 " + entry.sha256.substr(0, 12) +
                             "; nothing shipped");
  }
  copy_atomically(source, target);
  const auto metrics = archive_path(entry.sha256).replace_extension(".metrics.json");
  if (std::filesystem::exists(metrics)) copy_atomically(metrics, metrics_beside(target));
}

std::vector<std::string> Registry::repair() {
  const RegistryLock lock(folder_);
  load();
  std::vector<std::string> rewritten;
  for (const RegistryEntry& e : entries_) {
    const auto target = folder_ / e.file;
    if (std::filesystem::exists(target) && datasets::file_sha256_hex(target) == e.sha256) continue;
    materialize(e);
    rewritten.push_back(e.file);
  }
  return rewritten;
}

void Registry::adopt(const RegistryEntry& entry) {
  const RegistryLock lock(folder_);
  load();
  const auto file = folder_ / entry.file;
  archive(file, entry.sha256);
  if (std::filesystem::exists(metrics_beside(file))) {
    copy_atomically(metrics_beside(file),
                    archive_path(entry.sha256).replace_extension(".metrics.json"));
  }
  std::vector<RegistryEntry> next = entries_;
  auto it = std::find_if(next.begin(), next.end(),
                         [&](const RegistryEntry& e) { return e.name == entry.name; });
  if (it != next.end()) {
    *it = entry;
  } else {
    next.push_back(entry);
  }
  commit(std::move(next));
}

void Registry::promote(RegistryEntry entry, const std::filesystem::path& candidate,
                       const std::optional<std::filesystem::path>& metrics_file) {
  // Under the lock, from the manifest as it is now (another command may have changed it).
  const RegistryLock lock(folder_);
  load();
  entry.sha256 = datasets::file_sha256_hex(candidate);
  entry.promoted_utc = io::utc_now();
  const std::string name = entry.name;
  // 1. Both the candidate and the model it replaces are in the archive.
  archive(candidate, entry.sha256);
  if (metrics_file && std::filesystem::exists(*metrics_file)) {
    copy_atomically(*metrics_file, archive_path(entry.sha256).replace_extension(".metrics.json"));
  }
  std::vector<RegistryEntry> next = entries_;
  auto it = std::find_if(next.begin(), next.end(),
                         [&](const RegistryEntry& e) { return e.name == entry.name; });
  if (it != next.end()) {
    const auto shipped = folder_ / it->file;
    if (std::filesystem::exists(shipped) && datasets::file_sha256_hex(shipped) == it->sha256) {
      archive(shipped, it->sha256);
      if (std::filesystem::exists(metrics_beside(shipped))) {
        copy_atomically(metrics_beside(shipped),
                        archive_path(it->sha256).replace_extension(".metrics.json"));
      }
    }
    RegistryEntry previous = *it;
    entry.history = std::move(previous.history);
    previous.history.clear();
    entry.history.insert(entry.history.begin(), std::move(previous));
    *it = std::move(entry);
  } else {
    next.push_back(std::move(entry));
  }
  // 2. The commit point: one rename of the manifest (the entries change only when it is done).
  commit(std::move(next));
  // 3. The shipped file follows the manifest.
  materialize(*find(name));
}

RegistryEntry Registry::rollback(const std::string& name) {
  const RegistryLock lock(folder_);
  load();
  auto it = std::find_if(entries_.begin(), entries_.end(),
                         [&](const RegistryEntry& e) { return e.name == name; });
  if (it == entries_.end()) throw std::runtime_error("rollback: no shipped model '" + name + "'");
  if (it->history.empty()) {
    throw std::runtime_error("rollback: '" + name + "' has no earlier model to restore");
  }
  RegistryEntry restored = it->history.front();
  if (!std::filesystem::exists(archive_path(restored.sha256))) {
    throw std::runtime_error("rollback: the archive has no copy of " + name + " " +
                             restored.sha256.substr(0, 12));
  }
  restored.history.assign(it->history.begin() + 1, it->history.end());
  std::vector<RegistryEntry> next = entries_;
  next[static_cast<std::size_t>(it - entries_.begin())] = restored;
  commit(std::move(next));
  materialize(restored);
  return restored;
}

}  // namespace imm::pipeline
