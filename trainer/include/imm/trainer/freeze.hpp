#pragma once
/// `imm-train freeze`: turns a plain-IMM TOML config into a "plain_imm" model file. Nothing is
/// learned — the parameters are the config's — but the result is a model file like any trained
/// one (validated, provenance, metrics beside it), which the runtime and imm-track load, and
/// which the evaluations use as the reference IMM.

#include <filesystem>

namespace imm::trainer {

struct FreezeOptions {
  std::filesystem::path config;  ///< plain-IMM TOML
  std::filesystem::path out;     ///< model file to write
};

struct FreezeSummary {
  int modes = 0;
  int state_dimension = 0;
  double wall_seconds = 0.0;
};

/// Throws support::ConfigError for a bad config, io::FileError when the file cannot be written.
FreezeSummary freeze_plain_imm(const FreezeOptions& options);

}  // namespace imm::trainer
