// SPDX-License-Identifier: Apache-2.0
#include "stage_cache.hpp"

#include <link.h>

#include <algorithm>
#include <fstream>
#include <regex>

namespace imm::pipeline {
namespace {

// The regime file a trainer config names (regime = "…"), for the inputs digest.
std::optional<std::string> config_regime(const fs::path& config) {
  std::ifstream in(config);
  static const std::regex line(R"re(^\s*regime\s*=\s*"([^"]+)")re");
  for (std::string text; std::getline(in, text);) {
    std::smatch match;
    if (std::regex_search(text, match, line)) return match[1].str();
  }
  return std::nullopt;
}

// The track set a recorded regime file names ([recorded] set = "…"), if `path` is one.
std::optional<std::string> recorded_set(const fs::path& path) {
  if (path.extension() != ".toml") return std::nullopt;
  std::ifstream in(path);
  static const std::regex line(R"re(^\s*set\s*=\s*"([^"]+)")re");
  bool recorded = false;
  for (std::string text; std::getline(in, text);) {
    if (text.rfind('[', 0) == 0) recorded = text.rfind("[recorded]", 0) == 0;
    std::smatch match;
    if (recorded && std::regex_search(text, match, line)) return match[1].str();
  }
  return std::nullopt;
}

}  // namespace

std::vector<fs::path> project_libraries() {
  std::vector<fs::path> found;
  ::dl_iterate_phdr(
      [](dl_phdr_info* info, std::size_t /*size*/, void* data) {
        const fs::path path = info->dlpi_name == nullptr ? "" : info->dlpi_name;
        if (path.filename().string().starts_with("libimm")) {
          static_cast<std::vector<fs::path>*>(data)->push_back(path);
        }
        return 0;
      },
      &found);
  std::sort(found.begin(), found.end());
  return found;
}

std::string normal_path(const fs::path& path) {
  return fs::absolute(path).lexically_normal().string();
}

namespace {

// A sorted list of "name=digest" lines.
void hash_lines(datasets::Sha256& hash, const std::map<std::string, std::string>& files) {
  for (const auto& [name, digest] : files) {
    std::string line = name;
    line.append("=").append(digest).append("\n");
    hash.update(line);
  }
}

}  // namespace

std::string inputs_digest(const NightlyStage& stage, const fs::path& tool, Digests& digests,
                          const std::vector<std::string>& extra, const PlanOutputs& plan_outputs) {
  datasets::Sha256 hash;
  hash.update(stage.kind + '\n' + digests.of_file(tool) + '\n');
  // The tools load the project's shared libraries (the runtime) beside their own code: a rebuilt
  // runtime is a changed input even where the tool binaries are not.
  static const std::vector<fs::path> libraries = project_libraries();
  for (const fs::path& library : libraries) {
    hash.update(library.filename().string() + '=' + digests.of_file(library) + '\n');
  }
  for (const std::string& a : stage.arguments) hash.update(a + '\n');
  std::error_code error;
  auto add_file = [&](const fs::path& path) {
    if (!fs::is_regular_file(path, error)) return false;
    hash.update(path.string() + '=' + digests.of_file(path) + '\n');
    // A recorded regime's track set is an input of whatever names the regime.
    if (auto set = recorded_set(path); set && fs::is_regular_file(*set, error)) {
      hash.update(*set + '=' + digests.of_file(*set) + '\n');
    }
    return true;
  };
  for (const StageInput& input : stage.inputs) {
    const fs::path& path = input.path;
    hash.update(std::to_string(static_cast<int>(input.kind)) + ' ' + path.string() + '\n');
    switch (input.kind) {
      case StageInput::Kind::kFile:
        add_file(path);
        break;
      case StageInput::Kind::kTrainerConfig:
        if (add_file(path)) {
          if (auto regime = config_regime(path)) add_file(*regime);
        }
        break;
      case StageInput::Kind::kRecordings:
        if (fs::is_directory(path, error)) {
          std::map<std::string, std::string> files;  // the recordings, in name order
          for (const auto& f : fs::directory_iterator(path)) {
            if (f.is_regular_file())
              files[f.path().filename().string()] = digests.of_file(f.path());
          }
          hash_lines(hash, files);
        } else {
          add_file(path);
        }
        break;
      case StageInput::Kind::kVerdicts:
        // Written earlier tonight: read afresh, never from the digests taken before it was written.
        for (const char* name : {"metrics.json", "report.md"}) {
          const fs::path file = path / name;
          if (fs::is_regular_file(file, error)) {
            hash.update(file.string() + '=' + datasets::file_sha256_hex(file) + '\n');
          }
        }
        break;
      case StageInput::Kind::kModelFolder: {
        if (!fs::is_directory(path, error)) break;
        const std::string folder = normal_path(path);
        const std::string evaluated =
            stage.model_argument ? normal_path(stage.arguments[*stage.model_argument]) : "";
        std::map<std::string, std::string> files;  // path relative to the folder → digest
        for (const auto& [file, digest] : plan_outputs) {
          const fs::path relative = fs::path(file).lexically_relative(folder);
          if (!relative.empty() && *relative.begin() != ".." && file != evaluated) {
            files[relative.generic_string()] = "stage " + digest;
          }
        }
        for (const auto& f : fs::recursive_directory_iterator(path)) {
          const auto relative = f.path().lexically_relative(path).generic_string();
          if (f.is_regular_file() && f.path().extension() == ".h5" && relative[0] != '.' &&
              normal_path(f.path()) != evaluated && !files.contains(relative)) {
            files[relative] = digests.of_file(f.path());
          }
        }
        hash_lines(hash, files);
        break;
      }
    }
  }
  for (const auto& e : extra) hash.update(e + '\n');
  return hash.hex_digest();
}

}  // namespace imm::pipeline
