// SPDX-License-Identifier: Apache-2.0
#include "imm/pipeline/registry.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "imm/datasets/sha256.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/temporary_files.hpp"
#include "imm/trainer/provenance.hpp"
#include "registry_manifest.hpp"

namespace imm::pipeline {
namespace {

using trainer::copy_atomically;

// The registry's one lock (`<models>/.registry/lock`, flock): every change of the manifest holds
// it from reading the manifest to writing it, so two commands (a nightly's promotion, a rollback
// or a promotion by hand) never write from a stale copy. The lock dies with its process.
class RegistryLock {
 public:
  // `path`: the lock file, its folder checked by Registry::inside (no symbolic link on the way);
  // the file itself is never followed through a link either.
  explicit RegistryLock(const std::filesystem::path& path) {
    trainer::create_folders_durably(path.parent_path());
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
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

// Whether `path` is a regular file (not followed through a link) whose bytes have that SHA-256.
bool holds(const std::filesystem::path& path, const std::string& sha256) {
  std::error_code error;
  return std::filesystem::symlink_status(path, error).type() ==
             std::filesystem::file_type::regular &&
         datasets::file_sha256_hex(path) == sha256;
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

std::filesystem::path Registry::metrics_archive_path(const std::string& sha256) const {
  return folder_ / ".registry" / "archive" / (sha256 + ".metrics.json");
}

std::filesystem::path Registry::inside(const std::filesystem::path& relative,
                                       bool final_may_be_link) const {
  std::filesystem::path at = folder_;
  if (relative.empty()) return at;
  const auto last = std::prev(relative.end());
  for (auto part = relative.begin(); part != relative.end(); ++part) {
    at /= *part;
    std::error_code error;
    const auto type = std::filesystem::symlink_status(at, error).type();
    if (type == std::filesystem::file_type::symlink && !(final_may_be_link && part == last)) {
      throw std::runtime_error(at.string() +
                               ": is a symbolic link; the registry reads and writes only inside " +
                               folder_.string());
    }
    if (part != last && type != std::filesystem::file_type::not_found &&
        type != std::filesystem::file_type::directory) {
      throw std::runtime_error(at.string() + ": is not a folder");
    }
  }
  return at;
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
  const auto path = inside("manifest.json");
  if (const auto text = read_manifest_text(path)) entries_ = parse_manifest(*text, path.string());
}

void Registry::commit(std::vector<RegistryEntry> entries) {
  // The text it writes is the text a later load reads: refused here (another entry's file, say)
  // rather than committed and refused by every command after.
  const std::string text = manifest_text(entries);
  (void)parse_manifest(text, "the manifest a change would write");
  trainer::write_text_atomically(inside("manifest.json", true), text);
  entries_ = std::move(entries);
}

void Registry::remove_stale_temporaries() const {
  std::vector<std::filesystem::path> folders = {folder_, inside(".registry"),
                                                inside(".registry/archive")};
  for (const RegistryEntry& e : entries_) {
    folders.push_back(inside(std::filesystem::path(e.file).parent_path()));
  }
  for (const auto& folder : folders) {
    std::error_code error;
    if (!std::filesystem::is_directory(folder, error)) continue;
    bool removed = false;
    for (const auto& f : std::filesystem::directory_iterator(folder, error)) {
      if (io::is_stale_temporary(f.path().filename().string()) &&
          std::filesystem::remove(f.path(), error)) {
        removed = true;
      }
    }
    if (removed) trainer::sync_folder(folder);
  }
}

std::string Registry::archive_metrics(const std::optional<std::filesystem::path>& file) const {
  if (!file || !std::filesystem::exists(*file)) return std::string(kNoMetrics);
  std::string sha256 = datasets::file_sha256_hex(*file);
  const auto target =
      inside(std::filesystem::path(".registry/archive") / (sha256 + ".metrics.json"));
  if (!holds(target, sha256)) copy_atomically(*file, target);
  return sha256;
}

void Registry::archive(const std::filesystem::path& file, const std::string& sha256) const {
  const auto target = inside(std::filesystem::path(".registry/archive") / (sha256 + ".h5"));
  if (holds(target, sha256)) return;
  copy_atomically(file, target);
}

void Registry::require_materializable(const std::vector<RegistryEntry>& entries) const {
  for (const RegistryEntry& e : entries) {
    const auto target = inside(e.file, true);
    if (!holds(target, e.sha256) && !holds(archive_path(e.sha256), e.sha256)) {
      throw std::runtime_error("'" + e.name + "': neither " + target.string() +
                               " nor its archive copy has the sha256 " + e.sha256.substr(0, 12) +
                               "; the manifest is left as it was");
    }
    if (e.metrics_sha256.empty() || e.metrics_sha256 == kNoMetrics) continue;
    const auto beside = inside(trainer::metrics_path(e.file), true);
    if (!holds(beside, e.metrics_sha256) &&
        !holds(metrics_archive_path(e.metrics_sha256), e.metrics_sha256)) {
      throw std::runtime_error("'" + e.name + "': neither " + beside.string() +
                               " nor its archive copy has the metrics_sha256 " +
                               e.metrics_sha256.substr(0, 12) + "; the manifest is left as it was");
    }
  }
}

std::string shipped_file_problem(const std::filesystem::path& file, const std::string& sha256) {
  std::error_code error;
  const auto type = std::filesystem::symlink_status(file, error).type();
  if (type == std::filesystem::file_type::not_found) {
    return "is missing (the manifest's sha256 " + sha256.substr(0, 12) + ")";
  }
  if (type != std::filesystem::file_type::regular) return "is not a regular file";
  try {
    if (datasets::file_sha256_hex(file) == sha256) return "";
  } catch (const std::exception& failure) {
    return std::string("cannot be read: ") + failure.what();
  }
  return "differs from the manifest's sha256 " + sha256.substr(0, 12);
}

bool Registry::materialize(const RegistryEntry& entry) const {
  const auto target = inside(entry.file, true);
  bool rewritten = false;
  if (!holds(target, entry.sha256)) {
    const auto source = archive_path(entry.sha256);
    if (!std::filesystem::exists(source)) {
      throw std::runtime_error(target.string() + ": " + shipped_file_problem(target, entry.sha256) +
                               " and the archive has no copy");
    }
    // What is shipped is checked first: a damaged archive copy (a write cut short) is never
    // "restored" into models/.
    if (!holds(source, entry.sha256)) {
      throw std::runtime_error(source.string() + ": the archive copy of " + entry.file +
                               " does not match its sha256 " + entry.sha256.substr(0, 12) +
                               "; nothing shipped");
    }
    copy_atomically(source, target);
    rewritten = true;
  }
  // The metrics file beside a model is its own or none: never the one of the model it replaced.
  const auto beside = inside(trainer::metrics_path(entry.file), true);
  std::error_code error;
  const bool beside_exists = std::filesystem::symlink_status(beside, error).type() !=
                             std::filesystem::file_type::not_found;
  if (entry.metrics_sha256 == kNoMetrics) {
    if (beside_exists) {
      trainer::remove_durably(beside);
      rewritten = true;
    }
  } else if (!entry.metrics_sha256.empty() && !holds(beside, entry.metrics_sha256)) {
    const auto source = metrics_archive_path(entry.metrics_sha256);
    if (!holds(source, entry.metrics_sha256)) {
      throw std::runtime_error(beside.string() + ": differs from the manifest's metrics_sha256 " +
                               entry.metrics_sha256.substr(0, 12) +
                               " and the archive has no matching copy");
    }
    copy_atomically(source, beside);
    rewritten = true;
  }
  return rewritten;
}

// Archives what is shipped as the manifest says (a fresh clone's registry has no archive yet), so
// that a later rollback or repair finds every file it needs.
void Registry::archive_shipped(const RegistryEntry& e) const {
  const auto shipped = inside(e.file, true);
  if (holds(shipped, e.sha256)) archive(shipped, e.sha256);
  if (!e.metrics_sha256.empty() && e.metrics_sha256 != kNoMetrics) {
    const auto beside = inside(trainer::metrics_path(e.file), true);
    if (holds(beside, e.metrics_sha256)) (void)archive_metrics(beside);
  }
}

std::vector<std::string> Registry::repair() {
  const RegistryLock lock(inside(".registry/lock"));
  load();
  remove_stale_temporaries();
  std::vector<std::string> rewritten;
  for (const RegistryEntry& e : entries_) {
    archive_shipped(e);
    if (materialize(e)) rewritten.push_back(e.file);
  }
  // Entries written before `learned_part` was recorded get it from the file they ship (once).
  std::vector<RegistryEntry> described = entries_;
  bool changed = false;
  for (RegistryEntry& e : described) {
    if (!e.learned_part.empty()) continue;
    try {
      e.learned_part = learned_part_of(io::ModelFileReader(inside(e.file)).provenance());
      changed = true;
    } catch (const std::exception&) {
      // A file that does not read says nothing here; its own stage reports it.
    }
  }
  if (changed) commit(std::move(described));
  return rewritten;
}

void Registry::adopt(const RegistryEntry& entry) {
  const RegistryLock lock(inside(".registry/lock"));
  load();
  if (const std::string problem = model_name_problem(entry.name); !problem.empty()) {
    throw std::runtime_error("adopt: name " + problem);
  }
  if (const std::string problem = model_file_problem(entry.file); !problem.empty()) {
    throw std::runtime_error("adopt: file " + problem);
  }
  const auto file = inside(entry.file, true);
  archive(file, entry.sha256);
  RegistryEntry adopted = entry;
  adopted.metrics_sha256 = archive_metrics(metrics_beside(file));
  std::vector<RegistryEntry> next = entries_;
  auto it = std::find_if(next.begin(), next.end(),
                         [&](const RegistryEntry& e) { return e.name == entry.name; });
  if (it != next.end()) {
    adopted.history = std::move(it->history);
    adopted.rejected = std::move(it->rejected);
    *it = std::move(adopted);
  } else {
    next.push_back(std::move(adopted));
  }
  require_materializable(next);
  commit(std::move(next));
}

void Registry::promote(RegistryEntry entry, const std::filesystem::path& candidate,
                       const std::optional<std::filesystem::path>& metrics_file,
                       const PromotionTerms& terms) {
  // Under the lock, from the manifest as it is now (another command may have changed it).
  const RegistryLock lock(inside(".registry/lock"));
  load();
  remove_stale_temporaries();
  if (const std::string problem = model_name_problem(entry.name); !problem.empty()) {
    throw std::runtime_error("promote: name " + problem);
  }
  if (const std::string problem = model_file_problem(entry.file); !problem.empty()) {
    throw std::runtime_error("promote: file " + problem);
  }
  entry.sha256 = datasets::file_sha256_hex(candidate);
  entry.promoted_utc = io::utc_now();
  const std::string name = entry.name;
  const RegistryEntry* current = find(name);
  // The terms, decided on the manifest as it is now.
  if (terms.compared_with) {
    const std::string now = current != nullptr ? current->sha256 : "";
    if (now != *terms.compared_with) {
      const auto shown = [](const std::string& sha) {
        return sha.empty() ? std::string("none") : sha.substr(0, 12);
      };
      throw PromotionRefused(PromotionRefused::Why::kShippedModelChanged,
                             "'" + name +
                                 "': the shipped model changed while the candidate was "
                                 "evaluated (compared with " +
                                 shown(*terms.compared_with) + ", shipped now " + shown(now) +
                                 "); the candidate is compared with it first");
    }
  }
  if (terms.honour_rejections && current != nullptr) {
    for (const RegistryEntry& r : current->rejected) {
      if (is_rejected(r, candidate, entry.sha256, entry.inputs_digest)) {
        throw PromotionRefused(PromotionRefused::Why::kRolledBack,
                               "'" + name + "': the candidate is the model " +
                                   r.sha256.substr(0, 12) + " that was rolled back on " +
                                   r.rolled_back_utc,
                               r);
      }
    }
  }
  // 1. Both the candidate and the model it replaces (with their metrics files) are archived.
  archive(candidate, entry.sha256);
  entry.metrics_sha256 = archive_metrics(metrics_file);
  std::vector<RegistryEntry> next = entries_;
  auto it = std::find_if(next.begin(), next.end(),
                         [&](const RegistryEntry& e) { return e.name == entry.name; });
  if (it != next.end()) {
    archive_shipped(*it);
    // An entry from before metrics were recorded gets the metrics shipped beside it now.
    const auto shipped = inside(it->file, true);
    if (it->metrics_sha256.empty() && holds(shipped, it->sha256)) {
      it->metrics_sha256 = archive_metrics(metrics_beside(shipped));
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
    const auto existing = inside(entry.file, true);
    std::error_code error;
    if (std::filesystem::symlink_status(existing, error).type() ==
        std::filesystem::file_type::regular) {
      archive(existing, datasets::file_sha256_hex(existing));
    }
    next.push_back(std::move(entry));
  }
  // Every file it ships is at hand (commit() checks that the state reads back).
  require_materializable(next);
  // 2. The commit point: one rename of the manifest (the entries change only when it is done).
  commit(std::move(next));
  // 3. The shipped file follows the manifest.
  materialize(*find(name));
}

RegistryEntry Registry::rollback(const std::string& name) {
  const RegistryLock lock(inside(".registry/lock"));
  load();
  remove_stale_temporaries();
  auto it = std::find_if(entries_.begin(), entries_.end(),
                         [&](const RegistryEntry& e) { return e.name == name; });
  if (it == entries_.end()) {
    throw std::runtime_error("rollback: no shipped model " + quoted_for_message(name, 64));
  }
  if (it->history.empty()) {
    throw std::runtime_error("rollback: '" + name + "' has no earlier model to restore");
  }
  archive_shipped(*it);
  RegistryEntry restored = it->history.front();
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
  try {
    require_materializable({restored});
  } catch (const std::runtime_error& error) {
    throw std::runtime_error("rollback: " + std::string(error.what()));
  }
  commit(std::move(next));
  materialize(restored);
  return restored;
}

bool Registry::is_rejected(const RegistryEntry& r, const std::filesystem::path& candidate,
                           const std::string& sha256, const std::string& inputs) const {
  if (r.sha256 == sha256 || (!inputs.empty() && r.inputs_digest == inputs)) return true;
  const auto archived = archive_path(r.sha256);
  if (!holds(archived, r.sha256)) return false;
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
