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
  auto add_file = [&](const fs::path& path) {
    hash.update(path.string() + '=' + digests.of_file(path) + '\n');
  };
  for (std::size_t i = 0; i < stage.arguments.size(); ++i) {
    const std::string& a = stage.arguments[i];
    hash.update(a + '\n');
    // What it writes, and an evaluation's model (the model stage's output, digested there).
    if (stage.out_argument && i == *stage.out_argument) continue;
    if (i > 0 && (stage.arguments[i - 1] == "--out" || stage.arguments[i - 1] == "--out-dir" ||
                  (stage.kind == "data" && stage.arguments[i - 1] == "--csv"))) {
      continue;  // what the stage writes
    }
    if (stage.model_argument && i == *stage.model_argument) continue;
    std::error_code error;
    if (fs::is_regular_file(a, error)) {
      add_file(a);
      if (i > 0 && stage.arguments[i - 1] == "--config") {
        if (auto regime = config_regime(a); regime && fs::is_regular_file(*regime)) {
          add_file(*regime);
          if (auto set = recorded_set(*regime); set && fs::is_regular_file(*set)) add_file(*set);
        }
      }
      // A recorded regime's track set is an input of whatever names the regime.
      if (auto set = recorded_set(a); set && fs::is_regular_file(*set)) add_file(*set);
    } else if (fs::is_directory(a, error) && stage.kind == "data") {
      std::map<std::string, std::string> files;  // an import's recordings, in name order
      for (const auto& f : fs::directory_iterator(a)) {
        if (f.is_regular_file()) files[f.path().filename().string()] = digests.of_file(f.path());
      }
      for (const auto& [name, digest] : files) {
        std::string line = name;
        line.append("=").append(digest).append("\n");
        hash.update(line);
      }
    } else if (fs::is_directory(a, error) && stage.kind == "tracker") {
      // A candidate's evaluation folder: its verdict on its gates, written earlier tonight (so
      // read afresh, never from the digests taken before it was written).
      for (const char* name : {"metrics.json", "report.md"}) {
        const fs::path file = fs::path(a) / name;
        if (fs::is_regular_file(file, error)) {
          hash.update(file.string() + '=' + datasets::file_sha256_hex(file) + '\n');
        }
      }
    } else if (fs::is_directory(a, error) && stage.kind == "evaluation") {
      const std::string folder = normal_path(a);
      const std::string evaluated =
          stage.model_argument ? normal_path(stage.arguments[*stage.model_argument]) : "";
      std::map<std::string, std::string> files;  // path relative to the folder → digest
      for (const auto& [file, digest] : plan_outputs) {
        const fs::path relative = fs::path(file).lexically_relative(folder);
        if (!relative.empty() && *relative.begin() != ".." && file != evaluated) {
          files[relative.generic_string()] = "stage " + digest;
        }
      }
      for (const auto& f : fs::recursive_directory_iterator(a)) {
        const auto relative = f.path().lexically_relative(a).generic_string();
        if (f.is_regular_file() && f.path().extension() == ".h5" && relative[0] != '.' &&
            normal_path(f.path()) != evaluated && !files.contains(relative)) {
          files[relative] = digests.of_file(f.path());
        }
      }
      for (const auto& [relative, digest] : files) {
        std::string line = relative;
        line.append("=").append(digest).append("\n");
        hash.update(line);
      }
    }
  }
  for (const auto& e : extra) hash.update(e + '\n');
  return hash.hex_digest();
}

}  // namespace imm::pipeline
