// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The optional memetic step: a bounded derivative-free local search (NLopt's BOBYQA) polishes the
/// continuous parameters of the GA's best genome — the active rules' centers, spreads and
/// consequents — with the rule set fixed. The GA explores structure and coarse values; the local
/// search finishes the values, which mutation alone refines slowly.

#include "imm/trainer/ga/fuzzy_table_problem.hpp"

namespace imm::trainer::ga {

struct MemeticOptions {
  bool enabled = true;
  int max_evaluations = 400;
  double relative_tolerance = 1e-6;
};

struct MemeticResult {
  Genome genome;
  Evaluation before;
  Evaluation after;
  int evaluations = 0;
};

/// Returns the polished genome (never worse than `genome`: the better of start and result).
[[nodiscard]] MemeticResult polish(const FuzzyTableProblem& problem, const Genome& genome,
                                   const MemeticOptions& options);

}  // namespace imm::trainer::ga
