// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/provenance.hpp"

#include <unistd.h>

#include <fstream>
#include <sstream>
#include <stdexcept>

#include "imm/build_info.hpp"

namespace imm::trainer {

io::Provenance make_provenance(std::string model_kind, std::string config_toml, std::int64_t seed,
                               std::string dataset_digest) {
  io::Provenance provenance;
  provenance.model_kind = std::move(model_kind);
  provenance.created_utc = io::utc_now();
  provenance.trainer_version = kBuildVersion;
  provenance.seed = seed;
  provenance.config_toml = std::move(config_toml);
  provenance.dataset_digest = std::move(dataset_digest);
  return provenance;
}

io::Provenance make_provenance(std::string model_kind, std::string config_toml, std::int64_t seed,
                               std::string dataset_digest, const datasets::Regime& regime) {
  io::Provenance provenance = make_provenance(std::move(model_kind), std::move(config_toml), seed,
                                              std::move(dataset_digest));
  set_regime(provenance, regime);
  return provenance;
}

void set_regime(io::Provenance& provenance, const datasets::Regime& regime) {
  provenance.regime_name = regime.name;
  provenance.regime_toml = regime.text;
  provenance.regime_digest = regime.digest;
  provenance.length_unit = std::string(datasets::to_string(regime.units));
}

std::filesystem::path metrics_path(const std::filesystem::path& model_path) {
  return model_path.parent_path() / (model_path.stem().string() + ".metrics.json");
}

void ensure_parent_folder(const std::filesystem::path& path) {
  const auto folder = path.parent_path();
  if (!folder.empty()) std::filesystem::create_directories(folder);
}

namespace {

// The temporary beside `path` that an atomic write renames over it: ".<name>.tmp-<pid>" (the
// nightly removes stale ones).
std::filesystem::path temporary_beside(const std::filesystem::path& path) {
  std::string temp_name = ".";
  temp_name.append(path.filename().string()).append(".tmp-").append(std::to_string(::getpid()));
  return path.parent_path() / temp_name;
}

}  // namespace

void copy_atomically(const std::filesystem::path& from, const std::filesystem::path& to) {
  ensure_parent_folder(to);
  const auto temp = temporary_beside(to);
  std::filesystem::copy_file(from, temp, std::filesystem::copy_options::overwrite_existing);
  std::filesystem::rename(temp, to);
}

void write_text_atomically(const std::filesystem::path& path, const std::string& text) {
  ensure_parent_folder(path);
  const auto temp = temporary_beside(path);
  {
    std::ofstream out(temp, std::ios::trunc);
    out << text;
    out.flush();
    if (!out) throw std::runtime_error(temp.string() + ": cannot write");
  }
  std::filesystem::rename(temp, path);
}

void write_json_atomically(const std::filesystem::path& path, const nlohmann::json& document) {
  write_text_atomically(path, document.dump(2) + '\n');
}

std::string read_text_file(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path.string() + ": cannot open");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

}  // namespace imm::trainer
