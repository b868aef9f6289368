#pragma once
/// `imm-eval ga-imm`: seed 000's experiment (Table 3). On identical Monte Carlo noise: AIMM3 and
/// AIMM5 with the seed's intervals, the AIMM with intervals tuned on the training trajectories
/// (AIMM-tuned), a constant-q IMM with three tuned noise levels (IMM-tuned), the paper's published
/// rule tables run in our runtime (GA-IMM-paper) and our learned tables (GA-IMM). For the fuzzy
/// filters it also records how far q_j(k) moves (percentiles over scans, runs and axes).

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "imm/evaluation/monte_carlo.hpp"

namespace imm::evaluation {

struct GaImmExperimentOptions {
  std::filesystem::path model;            ///< our learned ga_fuzzy_imm model
  std::filesystem::path paper_model;      ///< the paper's tables (import-rules)
  std::filesystem::path training_config;  ///< GA config: training trajectories for the tuning
  int runs = 100;
  std::uint64_t seed = 1;
};

struct ProcessNoiseSpread {
  std::string filter, mode;
  double p01 = 0.0, p50 = 0.0, p99 = 0.0;
};

struct GaImmExperimentResult {
  int runs = 0, steps = 0;
  std::uint64_t seed = 0;
  std::string dataset_digest;
  std::vector<FilterOutcome>
      filters;  ///< AIMM3, AIMM5, AIMM-tuned, IMM-tuned, GA-IMM-paper, GA-IMM
  std::vector<ProcessNoiseSpread> spreads;
  std::map<std::string, std::string> tuned;       ///< tuned parameters, for the report
  std::map<std::string, double> training_scores;  ///< ζ_p + ζ_v on the training trajectories
};

[[nodiscard]] GaImmExperimentResult run_ga_imm_experiment(const GaImmExperimentOptions& options);

/// The paper's Table 3 (ζ_p, ζ_v) for the configurations it reports.
[[nodiscard]] const std::map<std::string, std::pair<double, double>>& seed000_table3();

}  // namespace imm::evaluation
