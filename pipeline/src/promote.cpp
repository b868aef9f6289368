// SPDX-License-Identifier: Apache-2.0
#include "imm/pipeline/promote.hpp"

#include <stdexcept>

#include "imm/io/file_error.hpp"
#include "imm/trainer/model_files/seal.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::pipeline {

RegistryEntry promote_by_hand(const PromoteOptions& options) {
  if (const std::string problem = model_name_problem(options.name); !problem.empty()) {
    throw std::runtime_error("promote: --name " + problem);
  }
  if (options.reason.find_first_not_of(" \t\n") == std::string::npos) {
    throw std::runtime_error("promote: --reason must say why the file is shipped past the gates");
  }
  if (!std::filesystem::is_regular_file(options.file)) {
    throw io::FileError(options.file.string(), "", "no such model file");
  }
  (void)trainer::check_model_file(options.file);
  RegistryEntry entry = describe_model(options.file, options.registry, options.name);
  if (from_uncommitted_code(entry)) {
    throw std::runtime_error(
        options.file.string() + ": trained by a build of uncommitted code (trainer_version " +
        entry.trainer_version + "); shipped models come only from committed code");
  }
  Registry registry(options.registry);
  (void)registry.repair();
  if (const RegistryEntry* current = registry.find(options.name)) {
    if (current->kind != entry.kind) {
      throw std::runtime_error("promote: '" + options.name + "' is a " + current->kind +
                               " model; " + options.file.string() + " holds a " + entry.kind +
                               " model");
    }
    entry.file = current->file;
  } else {
    entry.file = options.name + ".h5";
  }
  entry.promotion_reason = options.reason;
  const auto metrics = trainer::metrics_path(options.file);
  registry.promote(entry, options.file,
                   std::filesystem::exists(metrics) ? std::optional(metrics) : std::nullopt);
  return *registry.find(options.name);
}

}  // namespace imm::pipeline
