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
// metrics_sha256 of a model shipped without a metrics file.
constexpr std::string_view kNoMetrics = "none";

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
  if (!e.metrics_sha256.empty()) j["metrics_sha256"] = e.metrics_sha256;
  if (!e.learned_part.empty()) j["learned_part"] = e.learned_part;
  if (!e.history.empty()) {
    j["history"] = nlohmann::json::array();
    for (const RegistryEntry& h : e.history) j["history"].push_back(to_json(h));
  }
  if (!e.rejected.empty()) {
    j["rejected"] = nlohmann::json::array();
    for (const RegistryEntry& r : e.rejected) j["rejected"].push_back(to_json(r));
  }
  if (!e.rolled_back_utc.empty()) j["rolled_back_utc"] = e.rolled_back_utc;
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
    e.metrics_sha256 = j.value("metrics_sha256", "");
    e.learned_part = j.value("learned_part", "");
    if (!e.learned_part.empty() && e.learned_part != "on" && e.learned_part != "off" &&
        e.learned_part != "none") {
      throw std::runtime_error("learned_part: '" + e.learned_part +
                               "' is not \"on\", \"off\" or \"none\"");
    }
    if (j.contains("history")) {
      for (const auto& h : j.at("history")) e.history.push_back(from_json(h, where + ".history"));
    }
    if (j.contains("rejected")) {
      for (const auto& r : j.at("rejected")) {
        e.rejected.push_back(from_json(r, where + ".rejected"));
      }
    }
    e.rolled_back_utc = j.value("rolled_back_utc", "");
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
    if (!e.metrics_sha256.empty() && e.metrics_sha256 != kNoMetrics) {
      if (const std::string problem = sha256_problem(e.metrics_sha256); !problem.empty()) {
        throw std::runtime_error("metrics_sha256: " + problem + " or \"none\"");
      }
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

namespace {

std::string learned_part_of(const io::Provenance& p) {
  const auto it = p.training_metrics.find("learned_part_on");
  if (it == p.training_metrics.end()) return "none";
  return it->second > 0.5 ? "on" : "off";
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
  e.learned_part = learned_part_of(p);
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

std::filesystem::path Registry::metrics_archive_path(const std::string& sha256) const {
  return folder_ / ".registry" / "archive" / (sha256 + ".metrics.json");
}

std::string Registry::archive_metrics(const std::optional<std::filesystem::path>& file) const {
  if (!file || !std::filesystem::exists(*file)) return std::string(kNoMetrics);
  std::string sha256 = datasets::file_sha256_hex(*file);
  const auto target = metrics_archive_path(sha256);
  if (!std::filesystem::exists(target) || datasets::file_sha256_hex(target) != sha256) {
    copy_atomically(*file, target);
  }
  return sha256;
}

void Registry::archive(const std::filesystem::path& file, const std::string& sha256) const {
  const auto target = archive_path(sha256);
  if (std::filesystem::exists(target) && datasets::file_sha256_hex(target) == sha256) return;
  copy_atomically(file, target);
}

bool Registry::materialize(const RegistryEntry& entry) const {
  const auto target = folder_ / entry.file;
  bool rewritten = false;
  if (!std::filesystem::exists(target) || datasets::file_sha256_hex(target) != entry.sha256) {
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
    rewritten = true;
  }
  // The metrics file beside a model is its own or none: never the one of the model it replaced.
  const auto beside = metrics_beside(target);
  if (entry.metrics_sha256 == kNoMetrics) {
    if (std::filesystem::exists(beside)) {
      std::filesystem::remove(beside);
      rewritten = true;
    }
  } else if (!entry.metrics_sha256.empty() &&
             (!std::filesystem::exists(beside) ||
              datasets::file_sha256_hex(beside) != entry.metrics_sha256)) {
    const auto source = metrics_archive_path(entry.metrics_sha256);
    if (!std::filesystem::exists(source) ||
        datasets::file_sha256_hex(source) != entry.metrics_sha256) {
      throw std::runtime_error(beside.string() + ": differs from the manifest's metrics_sha256 " +
                               entry.metrics_sha256.substr(0, 12) +
                               " and the archive has no matching copy");
    }
    copy_atomically(source, beside);
    rewritten = true;
  }
  return rewritten;
}

std::vector<std::string> Registry::repair() {
  const RegistryLock lock(folder_);
  load();
  std::vector<std::string> rewritten;
  for (const RegistryEntry& e : entries_) {
    if (materialize(e)) rewritten.push_back(e.file);
  }
  // Entries written before `learned_part` was recorded get it from the file they ship (once).
  std::vector<RegistryEntry> described = entries_;
  bool changed = false;
  for (RegistryEntry& e : described) {
    if (!e.learned_part.empty()) continue;
    try {
      e.learned_part = learned_part_of(io::ModelFileReader(folder_ / e.file).provenance());
      changed = true;
    } catch (const std::exception&) {
      // A file that does not read says nothing here; its own stage reports it.
    }
  }
  if (changed) commit(std::move(described));
  return rewritten;
}

void Registry::adopt(const RegistryEntry& entry) {
  const RegistryLock lock(folder_);
  load();
  const auto file = folder_ / entry.file;
  archive(file, entry.sha256);
  RegistryEntry adopted = entry;
  adopted.metrics_sha256 = archive_metrics(metrics_beside(file));
  std::vector<RegistryEntry> next = entries_;
  auto it = std::find_if(next.begin(), next.end(),
                         [&](const RegistryEntry& e) { return e.name == entry.name; });
  if (it != next.end()) {
    *it = std::move(adopted);
  } else {
    next.push_back(std::move(adopted));
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
  entry.metrics_sha256 = archive_metrics(metrics_file);
  std::vector<RegistryEntry> next = entries_;
  auto it = std::find_if(next.begin(), next.end(),
                         [&](const RegistryEntry& e) { return e.name == entry.name; });
  if (it != next.end()) {
    const auto shipped = folder_ / it->file;
    if (std::filesystem::exists(shipped) && datasets::file_sha256_hex(shipped) == it->sha256) {
      archive(shipped, it->sha256);
      // An entry from before metrics were recorded gets the metrics shipped beside it now.
      if (it->metrics_sha256.empty()) it->metrics_sha256 = archive_metrics(metrics_beside(shipped));
    }
    RegistryEntry previous = *it;
    entry.history = std::move(previous.history);
    previous.history.clear();
    // The rejections stay with the name; promoting a rejected model (a person's decision) ends its.
    for (RegistryEntry& r : previous.rejected) {
      if (!is_rejected(r, candidate, entry.sha256, entry.inputs_digest)) {
        entry.rejected.push_back(std::move(r));
      }
    }
    previous.rejected.clear();
    entry.history.insert(entry.history.begin(), std::move(previous));
    *it = std::move(entry);
  } else {
    // A file under the name that the manifest does not know (one that could not be adopted) is
    // never overwritten without an archive copy.
    const auto existing = folder_ / entry.file;
    if (std::filesystem::exists(existing)) archive(existing, datasets::file_sha256_hex(existing));
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
  // The rolled-back model is recorded, so that the next night does not promote it again.
  RegistryEntry rejected = *it;
  rejected.history.clear();
  rejected.rejected.clear();
  rejected.rolled_back_utc = io::utc_now();
  restored.rejected = it->rejected;
  restored.rejected.insert(restored.rejected.begin(), std::move(rejected));
  std::vector<RegistryEntry> next = entries_;
  next[static_cast<std::size_t>(it - entries_.begin())] = restored;
  commit(std::move(next));
  materialize(restored);
  return restored;
}

bool Registry::is_rejected(const RegistryEntry& r, const std::filesystem::path& candidate,
                           const std::string& sha256, const std::string& inputs) const {
  if (r.sha256 == sha256 || (!inputs.empty() && r.inputs_digest == inputs)) return true;
  const auto archived = archive_path(r.sha256);
  if (!std::filesystem::exists(archived)) return false;
  try {
    return model_difference(candidate, archived).same();
  } catch (const std::exception&) {
    return false;  // a copy that does not read is no evidence of the same model
  }
}

std::optional<RegistryEntry> Registry::rejection(const std::string& name,
                                                 const std::filesystem::path& candidate,
                                                 const std::string& inputs_digest) const {
  const RegistryEntry* entry = find(name);
  if (entry == nullptr) return std::nullopt;
  const std::string sha256 = datasets::file_sha256_hex(candidate);
  for (const RegistryEntry& r : entry->rejected) {
    if (is_rejected(r, candidate, sha256, inputs_digest)) return r;
  }
  return std::nullopt;
}

}  // namespace imm::pipeline
