// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The shipped model files (models/, models/reference/; not the registry's archive), sorted, as
/// the tests that drill every shipped model iterate them (ctest runs in the source folder).

#include <algorithm>
#include <filesystem>
#include <vector>

namespace imm::testing {

inline std::vector<std::filesystem::path> shipped_models() {
  std::vector<std::filesystem::path> models;
  for (const char* folder : {"models", "models/reference"}) {
    for (const auto& entry : std::filesystem::directory_iterator(folder)) {
      if (entry.path().extension() == ".h5") models.push_back(entry.path());
    }
  }
  std::sort(models.begin(), models.end());
  return models;
}

}  // namespace imm::testing
