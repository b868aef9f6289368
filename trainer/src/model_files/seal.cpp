// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/model_files/seal.hpp"

#include <unistd.h>

#include <algorithm>
#include <system_error>

#include "imm/datasets/sha256.hpp"
#include "imm/io/container_file.hpp"
#include "imm/io/file_error.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/temporary_files.hpp"
#include "imm/load.hpp"

namespace imm::trainer {

std::string check_model_file(const std::filesystem::path& path) {
  const io::ModelFileReader reader(path);
  std::string kind = reader.provenance().model_kind;
  const auto& kinds = loadable_model_kinds();
  if (std::find(kinds.begin(), kinds.end(), kind) != kinds.end()) (void)load_filter(reader);
  return kind;
}

SealResult seal_model_file(const std::filesystem::path& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) {
    throw io::FileError(path.string(), "", "no such model file");
  }
  SealResult result;
  try {
    (void)check_model_file(path);
    result.before = "intact";
  } catch (const std::exception& problem) {
    result.before = problem.what();
  }
  const std::filesystem::path folder = path.parent_path().empty() ? "." : path.parent_path();
  // The writers' temporary pattern: a guard removes it if this process dies.
  const std::filesystem::path temp = folder / io::temporary_beside(path).filename();
  std::filesystem::copy_file(path, temp, std::filesystem::copy_options::overwrite_existing);
  try {
    io::seal_container(temp, io::kModelFormat);
    result.kind = check_model_file(temp);
    result.sha256 = datasets::file_sha256_hex(temp);
    std::filesystem::rename(temp, path);
  } catch (const io::FileError& problem) {  // named after the file the user gave
    std::filesystem::remove(temp, error);
    std::string prefix = problem.file();
    if (!problem.field().empty()) prefix += ": field '" + problem.field() + "'";
    prefix += ": ";
    const std::string text = problem.what();
    throw io::FileError(path.string(), problem.field(),
                        text.rfind(prefix, 0) == 0 ? text.substr(prefix.size()) : text);
  } catch (...) {
    std::filesystem::remove(temp, error);
    throw;
  }
  return result;
}

}  // namespace imm::trainer
