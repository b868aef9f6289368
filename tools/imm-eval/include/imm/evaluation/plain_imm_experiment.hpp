#pragma once
/// `imm-eval plain-imm`: the reference plain IMM (a "plain_imm" model file, by default the
/// three-level CV IMM of configs/track/cv3_imm.toml) on the seed-000 Monte Carlo experiment,
/// against each of its modes run alone as a single Kalman filter, on identical noise. Metrics are
/// seed 000's normalized errors ζ_p, ζ_v (see normalized_errors.hpp) and RMSEs.

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "imm/evaluation/monte_carlo.hpp"

namespace imm::evaluation {

struct PlainImmExperimentOptions {
  std::filesystem::path model;                ///< plain_imm model file
  std::optional<std::filesystem::path> data;  ///< a data-set file; else seed 000 is simulated
  int runs = 100;
  std::uint64_t seed = 1;
};

struct PlainImmExperimentResult {
  std::string scenario;
  int runs = 0;
  int steps = 0;
  std::uint64_t seed = 0;
  std::string dataset_digest;
  std::vector<FilterOutcome> filters;  ///< the IMM first, then its modes alone
};

[[nodiscard]] PlainImmExperimentResult run_plain_imm_experiment(
    const PlainImmExperimentOptions& options);

}  // namespace imm::evaluation
