// SPDX-License-Identifier: Apache-2.0
#pragma once
/// `imm-train freeze`: turns a plain-IMM TOML config into a "plain_imm" model file. Nothing is
/// learned — the parameters are the config's — but the result is a model file like any trained
/// one (validated, provenance, metrics beside it), which the runtime and imm-track load, and
/// which the evaluations use as the reference IMM. With a regime (`--regime`) the model records it
/// as the regime the filter is meant for, after checking that the filter fits it: the same sample
/// period, sensor kind and plot covariance (a support::ConfigError naming the filter's key
/// otherwise).

#include <filesystem>
#include <optional>

namespace imm::trainer {

struct FreezeOptions {
  std::filesystem::path config;                 ///< plain-IMM TOML
  std::filesystem::path out;                    ///< model file to write
  std::optional<std::filesystem::path> regime;  ///< the regime the filter is for
};

struct FreezeSummary {
  int modes = 0;
  int state_dimension = 0;
  double wall_seconds = 0.0;
};

/// Throws support::ConfigError for a bad config, io::FileError when the file cannot be written.
FreezeSummary freeze_plain_imm(const FreezeOptions& options);

}  // namespace imm::trainer
