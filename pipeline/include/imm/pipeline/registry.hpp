// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The model registry: what is shipped in models/, and the models it replaced.
///
/// `models/manifest.json` lists every shipped model (name, kind, regime name and digest, file,
/// SHA-256, schema version, trainer version, config digest, training date, the nightly inputs it
/// was trained from, and its test metrics with their uncertainty) and, per model, the entries it
/// replaced. The runtime needs none of it. Local state lives in `models/.registry/`: `archive/`
/// keeps every model file ever shipped by its SHA-256 (so a rollback restores it byte for byte)
/// and `staging/` the nightly's candidates.
///
/// Promotion is one atomic step: the candidate is archived, then the new manifest replaces the
/// old one with one rename, then the shipped file is written from the archive (temporary file +
/// rename). The manifest is the truth: `repair()` rewrites any shipped file whose bytes differ
/// from the manifest's SHA-256 from the archive, so a process killed between the two renames
/// leaves the old or the new manifest and, after repair, exactly its files.
///
/// Every change (repair, promote, rollback, adopt) holds the registry's one lock
/// (`.registry/lock`, flock) and re-reads the manifest under it before writing it, so commands
/// that run at the same time (a nightly, a rollback, a promotion by hand) never write from a stale
/// copy; a pointer from find() does not outlive the next change.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace imm::pipeline {

struct RegistryEntry {
  std::string name;  ///< the nightly stage's name, e.g. "ga_fuzzy_imm_agile_air"
  std::string kind;  ///< model_kind of the file
  std::string regime_name, regime_digest;
  std::string file;  ///< relative to the models folder
  std::string sha256;
  /// SHA-256 of the metrics file shipped beside it (<stem>.metrics.json), "none" when it ships
  /// without one (a stale one is removed), empty in entries written before it was recorded.
  std::string metrics_sha256;
  int schema_version = 0;
  std::string trainer_version;
  std::string config_digest;  ///< SHA-256 of the recorded config text
  std::string trained_utc;
  std::string inputs_digest;  ///< the nightly stage's inputs (empty: not from a nightly)
  std::string promoted_utc;
  nlohmann::json metrics = nlohmann::json::object();  ///< headline metrics with intervals
  /// Whether the model's learned part is on ("on"), switched off by its fit so that the file is its
  /// tuned baseline ("off"), or the kind has no such switch ("none"); from the file's
  /// `training.learned_part_on`. Empty in entries written before it was recorded (repair fills it
  /// in from the shipped file).
  std::string learned_part;
  /// Why a person promoted the file past the nightly's gates (`imm-train promote`); empty for a
  /// nightly promotion.
  std::string promotion_reason;
  std::vector<RegistryEntry> history;  ///< replaced entries, newest first
  /// Models a person rolled back from this name, newest first: the nightly does not promote the
  /// same model again (Registry::rejection) until a person says so.
  std::vector<RegistryEntry> rejected;
  std::string rolled_back_utc;  ///< of a rejected entry: when it was rolled back
};

/// Whether the entry's file was written by a build of uncommitted code (trainer_version "…-dirty"):
/// such a file is never shipped, by the nightly or by hand.
[[nodiscard]] bool from_uncommitted_code(const RegistryEntry& entry);

/// Why `name` cannot name a registry entry (empty when it can): one path component of letters,
/// digits, '_', '-' and '.', not starting with '.', at most 128 characters — a name becomes a
/// file name in the registry and must never lead out of it.
[[nodiscard]] std::string model_name_problem(std::string_view name);
/// Why `digest` is not a SHA-256 digest as the registry writes it (64 lowercase hex digits; empty
/// when it is): a digest names the archive copy a repair ships.
[[nodiscard]] std::string sha256_problem(std::string_view digest);

/// How the models in two files differ (model_difference).
struct ModelDifference {
  enum class Kind {
    kNone,       ///< the same model
    kValues,     ///< the same objects and attributes, other values (or shapes)
    kStructure,  ///< other objects, or other attributes on an object: a file holding a new field
  };
  Kind kind = Kind::kNone;
  std::string what;  ///< the first difference, for the log (empty for kNone)
  [[nodiscard]] bool same() const { return kind == Kind::kNone; }
};

/// How the models in two files differ. The same model: the same objects, the same attributes,
/// texts and integers equal, and every real equal to within 1e-6 of the largest magnitude of its
/// dataset (or attribute) — rounding, as another machine's libm or another summation order gives
/// it — except what says when and by which build a file was written (`created_utc`,
/// `trainer_version`) and how long its steps took (attributes named "…seconds"). Two trainings of
/// one definition that differ only in that are the same model: no news to ship.
[[nodiscard]] ModelDifference model_difference(const std::filesystem::path& a,
                                               const std::filesystem::path& b);

/// The registry entry of a model file (kind, regime, digests, dates from its provenance).
[[nodiscard]] RegistryEntry describe_model(const std::filesystem::path& file,
                                           const std::filesystem::path& models_folder,
                                           const std::string& name);

class Registry {
 public:
  /// Opens the registry of `models_folder` (no manifest yet: empty).
  explicit Registry(std::filesystem::path models_folder);

  [[nodiscard]] const std::filesystem::path& folder() const { return folder_; }
  [[nodiscard]] std::filesystem::path manifest_path() const { return folder_ / "manifest.json"; }
  [[nodiscard]] std::filesystem::path staging_folder() const;
  [[nodiscard]] std::filesystem::path archive_path(const std::string& sha256) const;

  [[nodiscard]] const std::vector<RegistryEntry>& entries() const { return entries_; }
  [[nodiscard]] const RegistryEntry* find(const std::string& name) const;
  /// The entries of a kind (model_kind or nightly command) and regime name.
  [[nodiscard]] std::vector<const RegistryEntry*> find(const std::string& kind,
                                                       const std::string& regime) const;

  /// Makes every shipped file and its metrics file match the manifest (restoring from the
  /// archive); returns the files it rewrote. Throws std::runtime_error when a needed archived file
  /// is missing.
  std::vector<std::string> repair();

  /// Ships `candidate` (a model file) as `entry.name` at `entry.file`, with its metrics file
  /// (optional) beside it; the entry it replaces goes to the history. Atomic as described above.
  void promote(RegistryEntry entry, const std::filesystem::path& candidate,
               const std::optional<std::filesystem::path>& metrics_file = std::nullopt);

  /// Restores the entry before the current one of `name` and records the current one as rejected
  /// (in the restored entry's `rejected`, with the time); returns the restored entry. Throws
  /// std::runtime_error when there is none.
  RegistryEntry rollback(const std::string& name);

  /// The model rolled back from `name` that `candidate` is again — the same file, the same nightly
  /// inputs, or the same model but for its build and date (model_difference against the archived
  /// copy) — or nothing. A promotion of such a candidate (by hand, or a nightly with --force)
  /// clears the record.
  [[nodiscard]] std::optional<RegistryEntry> rejection(const std::string& name,
                                                       const std::filesystem::path& candidate,
                                                       const std::string& inputs_digest) const;

  /// Records an existing shipped file without promotion (a manifest started from models/).
  void adopt(const RegistryEntry& entry);

 private:
  void load();
  /// Writes `entries` as the manifest (the commit point), then makes them the registry's: a save
  /// that throws leaves the registry's entries as they were, so a failed step is never committed
  /// by the next one.
  void commit(std::vector<RegistryEntry> entries);
  void archive(const std::filesystem::path& file, const std::string& sha256) const;
  /// Where the archive keeps a metrics file, by its own SHA-256.
  [[nodiscard]] std::filesystem::path metrics_archive_path(const std::string& sha256) const;
  /// Archives a metrics file (when there is one); returns its SHA-256, or "none".
  std::string archive_metrics(const std::optional<std::filesystem::path>& file) const;
  /// Makes the shipped file (and its metrics file: the archived one, or none) the entry's; returns
  /// whether it rewrote either.
  bool materialize(const RegistryEntry& entry) const;
  /// Whether `candidate` (with that SHA-256 and nightly inputs) is the rejected model `r`.
  [[nodiscard]] bool is_rejected(const RegistryEntry& r, const std::filesystem::path& candidate,
                                 const std::string& sha256, const std::string& inputs) const;

  std::filesystem::path folder_;
  std::vector<RegistryEntry> entries_;
};

}  // namespace imm::pipeline
