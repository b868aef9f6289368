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
/// copy, and decides on the manifest as it is then: a nightly's promotion states which model it was
/// compared with and is refused when another is shipped by then, or when the candidate was rolled
/// back meanwhile (PromotionTerms). A pointer from find() does not outlive the next change.
///
/// No change commits a manifest it cannot materialize: every file the new state ships (the model
/// and its metrics file) is checked first, shipped or archived with its SHA-256.
///
/// A manifest can arrive by `git pull`, so it is validated before use: a regular file of at most
/// kMaxManifestBytes nested at most kMaxManifestDepth deep, every field of its type (the refusal
/// names the field), names and files confined to their own places (a file is never the registry's
/// own, another entry's or its metrics file), and nothing is written through a symbolic link
/// under the models folder.

#include <cstdint>
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

/// Why `file` cannot be where a model ships (empty when it can): a relative path of components that
/// are names (model_name_problem's characters, none starting with '.'), ending in ".h5" but not
/// in ".metrics.json" — never the manifest, the registry's own folder or a path out of the models
/// folder.
[[nodiscard]] std::string model_file_problem(std::string_view file);

/// The largest manifest read (bytes) and its deepest nesting of JSON arrays and objects.
inline constexpr std::uintmax_t kMaxManifestBytes = std::uintmax_t{16} << 20U;
inline constexpr int kMaxManifestDepth = 24;

/// The entries of a manifest's text, validated as described above; `where` prefixes every
/// refusal (std::runtime_error naming the field: "models[2].regime.name: expected a string").
[[nodiscard]] std::vector<RegistryEntry> parse_manifest(std::string_view text,
                                                        const std::string& where);

/// `text` for a one-line message: control bytes, bytes of malformed UTF-8 and the characters that
/// could mislead a terminal (C1 and bidirectional controls) as \xNN (\n, \r, \t by name), other
/// characters as they are (ζ, —), and at most `limit` bytes of it, whole characters, the rest
/// counted.
[[nodiscard]] std::string quoted_for_message(std::string_view text, std::size_t limit = 160);

/// Why `file` is not the shipped file of that SHA-256, for a message ("is missing (the manifest's
/// sha256 …)", "is not a regular file", "differs from the manifest's sha256 …", "cannot be read:
/// …"), or "" when it is.
[[nodiscard]] std::string shipped_file_problem(const std::filesystem::path& file,
                                               const std::string& sha256);

/// What a promotion requires of the manifest as it is under the lock.
struct PromotionTerms {
  /// The SHA-256 of the shipped model the candidate was compared with ("" when none was shipped
  /// under the name): when another is shipped by then, the promotion is refused. Nothing: no such
  /// condition (a promotion by hand).
  std::optional<std::string> compared_with;
  /// Refuse a candidate that a person rolled back under the name (Registry::rejection), as the
  /// manifest says then.
  bool honour_rejections = false;
};

/// A promotion refused by its terms; the registry is unchanged.
class PromotionRefused : public std::runtime_error {
 public:
  enum class Why {
    kShippedModelChanged,  ///< another model is shipped than the one compared with
    kRolledBack,           ///< the candidate is a model a person rolled back
  };
  PromotionRefused(Why why, const std::string& message, std::optional<RegistryEntry> rejected = {})
      : std::runtime_error(message), why_(why), rejected_(std::move(rejected)) {}
  [[nodiscard]] Why why() const { return why_; }
  /// The rejection record (kRolledBack).
  [[nodiscard]] const std::optional<RegistryEntry>& rejected() const { return rejected_; }

 private:
  Why why_;
  std::optional<RegistryEntry> rejected_;
};

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
  /// Throws PromotionRefused (changing nothing) when the manifest under the lock breaks `terms`.
  void promote(RegistryEntry entry, const std::filesystem::path& candidate,
               const std::optional<std::filesystem::path>& metrics_file = std::nullopt,
               const PromotionTerms& terms = {});

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

  /// Records an existing shipped file without promotion (a manifest started from models/); an
  /// entry of that name keeps its history and rejections.
  void adopt(const RegistryEntry& entry);

  /// Reads the manifest again (outside any change: what another command committed since).
  void reload() { load(); }

 private:
  void load();
  /// Refuses (std::runtime_error naming the entry and the file) a state whose files cannot all be
  /// shipped: each entry's model and metrics file is shipped or archived with its SHA-256.
  void require_materializable(const std::vector<RegistryEntry>& entries) const;
  /// Archives the entry's shipped model and metrics file where they match the manifest.
  void archive_shipped(const RegistryEntry& entry) const;
  /// Removes this host's temporaries of dead processes from the registry's folders.
  void remove_stale_temporaries() const;
  /// `folder_ / relative`, refused when a component under the models folder is a symbolic link
  /// (the last one may be a link only where `final_may_be_link`: it is replaced, never followed).
  [[nodiscard]] std::filesystem::path inside(const std::filesystem::path& relative,
                                             bool final_may_be_link = false) const;
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
