#pragma once
/// `imm-eval wimm`: seed 004's experiment (Table 2). Scenario 1 (constant velocity) and scenario 2
/// (two coordinated turns), 100 Monte Carlo runs, every filter on identical plots: the seed's
/// normal IMM (nIMM), the weighted IMM of the model file (wIMM), the weighted IMM with the seed's
/// own threshold and α (wIMM-seed), the correlated fusion (wIMM-correlated, equal to the nIMM by
/// derivation), and the normal IMM with q₁ and P(CV→CV) tuned on the training scenarios
/// (nIMM-tuned).

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "imm/trainer/wimm/tracking_score.hpp"

namespace imm::evaluation {

struct WimmExperimentOptions {
  std::filesystem::path model;            ///< wimm model file
  std::filesystem::path training_config;  ///< configs/wimm.toml (training scenarios, nIMM)
  int runs = 100;
  std::uint64_t seed = 1;
};

struct WimmRow {
  std::string filter;
  trainer::wimm::TrackingScore score;
};

struct WimmScenarioResult {
  int number = 0;
  std::vector<WimmRow> rows;  ///< nIMM first
};

struct WimmExperimentResult {
  int runs = 0;
  std::uint64_t seed = 0;
  std::vector<WimmScenarioResult> scenarios;
  std::map<std::string, std::string> parameters;  ///< threshold/α of wIMM, tuned nIMM values
};

[[nodiscard]] WimmExperimentResult run_wimm_experiment(const WimmExperimentOptions& options);

}  // namespace imm::evaluation
