// SPDX-License-Identifier: Apache-2.0
// The registry's manifest as text: written from entries, and read back as a hostile document
// (it can arrive by `git pull`): bounded depth before any parse, every field of its type and
// named when refused, names and files confined to their places.
#include "registry_manifest.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <map>
#include <stdexcept>

#include "imm/trainer/provenance.hpp"

namespace imm::pipeline {
namespace {

constexpr int kManifestVersion = 1;
// The longest text field the registry keeps (a reason, a date, a version, a digest).
constexpr std::size_t kMaxTextBytes = 4096;

// Where a field is, for a refusal: "models[2].regime.name".
std::string member(const std::string& where, std::string_view key) {
  return where + "." + std::string(key);
}

std::string type_of(const nlohmann::json& j) {
  if (j.is_null()) return "null";
  if (j.is_boolean()) return "a boolean";
  if (j.is_number()) return "a number";
  if (j.is_string()) return "a string";
  if (j.is_array()) return "an array";
  return "an object";
}

// The fields of one JSON object, each read with its type checked and its key in the refusal.
class Fields {
 public:
  Fields(const nlohmann::json& j, std::string where) : j_(j), where_(std::move(where)) {
    if (!j_.is_object()) fail(where_, "expected an object, found " + type_of(j_));
  }

  [[nodiscard]] const std::string& where() const { return where_; }

  [[noreturn]] static void fail(const std::string& field, const std::string& why) {
    throw std::runtime_error(field + ": " + why);
  }

  [[nodiscard]] const nlohmann::json* find(std::string_view key) const {
    const auto it = j_.find(key);
    return it == j_.end() ? nullptr : &*it;
  }

  // A text of at most kMaxTextBytes; absent → `fallback` (or a refusal when it is required).
  [[nodiscard]] std::string text(std::string_view key, bool required,
                                 const std::string& fallback = "") const {
    const nlohmann::json* value = find(key);
    if (value == nullptr) {
      if (required) fail(member(where_, key), "missing");
      return fallback;
    }
    if (!value->is_string()) {
      fail(member(where_, key), "expected a string, found " + type_of(*value));
    }
    const auto& s = value->get_ref<const std::string&>();
    if (s.size() > kMaxTextBytes) {
      fail(member(where_, key), "is " + std::to_string(s.size()) + " bytes long (at most " +
                                    std::to_string(kMaxTextBytes) + ")");
    }
    return s;
  }

  // A text of one line of printable characters (what the registry prints as a cell or a path).
  [[nodiscard]] std::string line(std::string_view key, bool required) const {
    std::string s = text(key, required);
    if (std::any_of(s.begin(), s.end(), [](char c) {
          const auto u = static_cast<unsigned char>(c);
          return u < 0x20 || u == 0x7f;
        })) {
      fail(member(where_, key), quoted_for_message(s) + " holds a control character");
    }
    return s;
  }

  [[nodiscard]] int integer(std::string_view key) const {
    const nlohmann::json* value = find(key);
    if (value == nullptr) fail(member(where_, key), "missing");
    if (!value->is_number_integer() || value->get<std::int64_t>() < 0 ||
        value->get<std::int64_t>() > 1'000'000) {
      fail(member(where_, key), "expected an integer from 0 to 1000000, found " +
                                    (value->is_number() ? value->dump() : type_of(*value)));
    }
    return value->get<int>();
  }

  [[nodiscard]] const nlohmann::json* array(std::string_view key) const {
    const nlohmann::json* value = find(key);
    if (value != nullptr && !value->is_array()) {
      fail(member(where_, key), "expected an array, found " + type_of(*value));
    }
    return value;
  }

 private:
  const nlohmann::json& j_;
  std::string where_;
};

// The deepest nesting of arrays and objects in a JSON text, without parsing it (nlohmann's parser
// and its destructor recurse per level: a manifest nested 10⁵ deep would overflow the stack).
int nesting_depth(std::string_view text) {
  int depth = 0, deepest = 0;
  bool in_string = false, escaped = false;
  for (const char c : text) {
    if (in_string) {
      if (escaped) {
        escaped = false;
      } else if (c == '\\') {
        escaped = true;
      } else if (c == '"') {
        in_string = false;
      }
      continue;
    }
    if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return deepest;
}

RegistryEntry from_json(const nlohmann::json& j, const std::string& where, bool nested) {
  const Fields f(j, where);
  RegistryEntry e;
  e.name = f.text("name", true);
  if (const std::string problem = model_name_problem(e.name); !problem.empty()) {
    Fields::fail(member(where, "name"), problem);
  }
  e.kind = f.line("kind", true);
  const nlohmann::json* regime = f.find("regime");
  if (regime == nullptr) Fields::fail(member(where, "regime"), "missing");
  const Fields r(*regime, member(where, "regime"));
  e.regime_name = r.line("name", true);
  e.regime_digest = r.line("digest", true);
  e.file = f.text("file", true);
  if (const std::string problem = model_file_problem(e.file); !problem.empty()) {
    Fields::fail(member(where, "file"), problem);
  }
  e.sha256 = f.text("sha256", true);
  if (const std::string problem = sha256_problem(e.sha256); !problem.empty()) {
    Fields::fail(member(where, "sha256"), quoted_for_message(e.sha256) + " " + problem);
  }
  e.schema_version = f.integer("schema_version");
  e.trainer_version = f.line("trainer_version", true);
  e.config_digest = f.line("config_digest", true);
  e.trained_utc = f.line("trained_utc", true);
  e.inputs_digest = f.line("inputs_digest", false);
  e.promoted_utc = f.line("promoted_utc", false);
  if (const nlohmann::json* metrics = f.find("metrics")) {
    if (!metrics->is_object()) {
      Fields::fail(member(where, "metrics"), "expected an object, found " + type_of(*metrics));
    }
    e.metrics = *metrics;
  }
  e.promotion_reason = f.text("promotion_reason", false);
  e.metrics_sha256 = f.text("metrics_sha256", false);
  if (!e.metrics_sha256.empty() && e.metrics_sha256 != kNoMetrics) {
    if (const std::string problem = sha256_problem(e.metrics_sha256); !problem.empty()) {
      Fields::fail(member(where, "metrics_sha256"),
                   quoted_for_message(e.metrics_sha256) + " " + problem + " or \"none\"");
    }
  }
  e.learned_part = f.text("learned_part", false);
  if (!e.learned_part.empty() && e.learned_part != "on" && e.learned_part != "off" &&
      e.learned_part != "none") {
    Fields::fail(member(where, "learned_part"),
                 quoted_for_message(e.learned_part) + " is not \"on\", \"off\" or \"none\"");
  }
  e.rolled_back_utc = f.line("rolled_back_utc", false);
  for (const char* list : {"history", "rejected"}) {
    const nlohmann::json* items = f.array(list);
    if (items == nullptr) continue;
    // A replaced or rejected entry is recorded flat (its own history and rejections are its
    // name's): no chain of entries inside entries.
    if (nested && !items->empty()) {
      Fields::fail(member(where, list),
                   "a replaced or rejected entry has no " + std::string(list) + " of its own");
    }
    auto& target = std::string_view(list) == "history" ? e.history : e.rejected;
    for (std::size_t i = 0; i < items->size(); ++i) {
      RegistryEntry item =
          from_json((*items)[i], member(where, list) + "[" + std::to_string(i) + "]", true);
      if (item.name != e.name) {
        Fields::fail(member(where, list) + "[" + std::to_string(i) + "].name",
                     quoted_for_message(item.name) + " is not the entry's name '" + e.name + "'");
      }
      target.push_back(std::move(item));
    }
  }
  return e;
}

}  // namespace

namespace {

// The length of the well-formed UTF-8 sequence at text[i] of a printable character at or above
// U+00A0 (no overlong form, surrogate, C1 control or bidirectional control, which could reorder
// what a terminal shows around it), else 0.
std::size_t printable_utf8_at(std::string_view text, std::size_t i) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[i + k]); };
  const unsigned char lead = byte(0);
  const std::size_t n = lead >= 0xf0 ? 4 : lead >= 0xe0 ? 3 : lead >= 0xc0 ? 2 : 0;
  if (n == 0 || lead >= 0xf5 || i + n > text.size()) return 0;
  std::uint32_t cp = lead & (0x7fU >> n);
  for (std::size_t k = 1; k < n; ++k) {
    if ((byte(k) & 0xc0U) != 0x80U) return 0;
    cp = (cp << 6U) | (byte(k) & 0x3fU);
  }
  constexpr std::uint32_t kLeast[] = {0, 0, 0x80, 0x800, 0x10000};
  const bool bidi = cp == 0x061c || cp == 0x200e || cp == 0x200f ||
                    (cp >= 0x202a && cp <= 0x202e) || (cp >= 0x2066 && cp <= 0x2069);
  if (cp < kLeast[n] || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff) || cp < 0xa0 || bidi) {
    return 0;
  }
  return n;
}

}  // namespace

std::string quoted_for_message(std::string_view text, std::size_t limit) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out = "'";
  const std::size_t shown = std::min(text.size(), limit);
  std::size_t i = 0;
  while (i < shown) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (const std::size_t n = c >= 0x80 ? printable_utf8_at(text, i) : 0; n > 0) {
      if (i + n > shown) break;  // a character is shown whole or not at all
      out.append(text.substr(i, n));
      i += n;
      continue;
    }
    if (c == '\n') {
      out += "\\n";
    } else if (c == '\r') {
      out += "\\r";
    } else if (c == '\t') {
      out += "\\t";
    } else if (c < 0x20 || c >= 0x7f || c == '\\') {
      out += "\\x";
      out.push_back(kHex[c >> 4U]);
      out.push_back(kHex[c & 0xfU]);
    } else {
      out.push_back(static_cast<char>(c));
    }
    ++i;
  }
  out += "'";
  if (i < text.size()) out += " (" + std::to_string(text.size()) + " bytes in all)";
  return out;
}

std::string model_name_problem(std::string_view name) {
  const std::string quoted = quoted_for_message(name, 64);
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

std::string model_file_problem(std::string_view file) {
  const std::string quoted = quoted_for_message(file, 64);
  if (file.empty() || file.size() > 512) return quoted + " must have 1 to 512 characters";
  if (!file.ends_with(".h5") || file.ends_with(".metrics.json")) {
    return quoted + " must name a model file (ending in \".h5\")";
  }
  std::size_t start = 0;
  int components = 0;
  while (start <= file.size()) {
    const std::size_t end = std::min(file.find('/', start), file.size());
    const std::string_view part = file.substr(start, end - start);
    if (!model_name_problem(part).empty()) {
      return quoted +
             " must be a path inside the models folder whose every component is a name "
             "(letters, digits, '_', '-' and '.', not starting with '.')";
    }
    if (++components > 8) return quoted + " is nested more than 8 folders deep";
    start = end + 1;
  }
  return "";
}

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

std::string manifest_text(const std::vector<RegistryEntry>& entries) {
  nlohmann::json document = {{"manifest_version", kManifestVersion},
                             {"models", nlohmann::json::array()}};
  for (const RegistryEntry& e : entries) document["models"].push_back(to_json(e));
  return document.dump(2) + '\n';
}

std::vector<RegistryEntry> parse_manifest(std::string_view text, const std::string& where) {
  if (text.size() > kMaxManifestBytes) {
    throw std::runtime_error(where + ": " + std::to_string(text.size()) + " bytes (at most " +
                             std::to_string(kMaxManifestBytes) + ")");
  }
  if (const int depth = nesting_depth(text); depth > kMaxManifestDepth) {
    // Bytes that are not JSON at all (a model file put in its place) are said to be so: their
    // brackets counted as nesting would mislead. accept() builds nothing and recurses nowhere.
    if (!nlohmann::json::accept(text)) throw std::runtime_error(where + ": not JSON");
    throw std::runtime_error(where + ": nested " + std::to_string(depth) +
                             " levels deep (at most " + std::to_string(kMaxManifestDepth) + ")");
  }
  nlohmann::json document;
  try {
    document = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& error) {
    throw std::runtime_error(where + ": not JSON (" + error.what() + ")");
  }
  const nlohmann::json* version = document.is_object() && document.contains("manifest_version")
                                      ? &document.at("manifest_version")
                                      : nullptr;
  if (version == nullptr || !version->is_number_integer() ||
      version->get<std::int64_t>() != kManifestVersion || !document.contains("models") ||
      !document.at("models").is_array()) {
    throw std::runtime_error(where + ": manifest_version: expected " +
                             std::to_string(kManifestVersion) + " with a 'models' array");
  }
  std::vector<RegistryEntry> entries;
  // Every path the registry writes for an entry (its file and its metrics file), and whose.
  std::map<std::string, std::string> owners;
  const auto claim = [&](const std::string& path, const std::string& name,
                         const std::string& field) {
    const auto [it, fresh] = owners.emplace(path, name);
    if (!fresh && it->second != name) {
      throw std::runtime_error(field + ": '" + path + "' is also where '" + it->second +
                               "' ships; every entry has files of its own");
    }
  };
  const auto& models = document.at("models");
  for (std::size_t i = 0; i < models.size(); ++i) {
    const std::string at = where + ": models[" + std::to_string(i) + "]";
    try {
      entries.push_back(from_json(models[i], "models[" + std::to_string(i) + "]", false));
    } catch (const std::runtime_error& error) {
      throw std::runtime_error(where + ": " + error.what());
    }
    const RegistryEntry& e = entries.back();
    for (std::size_t k = 0; k + 1 < entries.size(); ++k) {
      if (entries[k].name == e.name) {
        throw std::runtime_error(at + ".name '" + e.name + "' appears twice");
      }
    }
    const std::vector<const RegistryEntry*> versions = [&] {
      std::vector<const RegistryEntry*> all = {&e};
      for (const auto& h : e.history) all.push_back(&h);
      for (const auto& r : e.rejected) all.push_back(&r);
      return all;
    }();
    for (const RegistryEntry* v : versions) {
      claim(v->file, e.name, at + ".file");
      claim(trainer::metrics_path(v->file).generic_string(), e.name, at + ".file");
    }
  }
  return entries;
}

// The manifest's text: a regular file (never a FIFO, a device or a link) of at most
// kMaxManifestBytes, or nothing when there is none.
std::optional<std::string> read_manifest_text(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
  if (fd < 0) {
    if (errno == ENOENT) return std::nullopt;
    const std::string why = errno == ELOOP ? "is a symbolic link" : std::strerror(errno);
    throw std::runtime_error(path.string() + ": cannot read the manifest: " + why);
  }
  std::string text;
  try {
    struct stat info {};
    if (::fstat(fd, &info) != 0 || !S_ISREG(info.st_mode)) {
      throw std::runtime_error(path.string() + ": the manifest is not a regular file");
    }
    if (static_cast<std::uintmax_t>(info.st_size) > kMaxManifestBytes) {
      throw std::runtime_error(path.string() + ": the manifest has " +
                               std::to_string(info.st_size) + " bytes (at most " +
                               std::to_string(kMaxManifestBytes) + ")");
    }
    text.resize(static_cast<std::size_t>(info.st_size));
    std::size_t done = 0;
    while (done < text.size()) {
      const ssize_t n = ::read(fd, text.data() + done, text.size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) throw std::runtime_error(path.string() + ": read: " + std::strerror(errno));
      if (n == 0) break;
      done += static_cast<std::size_t>(n);
    }
    text.resize(done);
  } catch (...) {
    ::close(fd);
    throw;
  }
  ::close(fd);
  return text;
}

}  // namespace imm::pipeline
