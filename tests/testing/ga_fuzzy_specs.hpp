// SPDX-License-Identifier: Apache-2.0
#pragma once
// Random GA-fuzzy IMM specs, for tests that compare two implementations of the filter.

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "imm/datasets/random.hpp"
#include "imm/filters/ga_fuzzy_imm.hpp"

namespace imm::testing {

// A table of `rules` random rules: centres within ±scale, spreads 0.05–2 × scale, consequents
// 1e-9 … 1e-2.
inline FuzzyRuleTable random_fuzzy_table(datasets::Rng& rng, int rules, double scale) {
  std::vector<FuzzyRule> table;
  table.reserve(static_cast<std::size_t>(rules));
  for (int l = 0; l < rules; ++l) {
    table.push_back({rng.uniform(-scale, scale), rng.uniform(0.05, 2.0) * scale,
                     rng.uniform(-scale, scale), rng.uniform(0.05, 2.0) * scale,
                     std::pow(10.0, rng.uniform(-9.0, -2.0))});
  }
  return FuzzyRuleTable(std::move(table));
}

// T = 1 s and σ_z = 0.5 (set them after, where a test varies them), random mode switching, and
// `levels` random tables of 1 … 6 rules at the scale of what `antecedents` reads.
inline GaFuzzyImmSpec random_ga_fuzzy_spec(datasets::Rng& rng, int levels,
                                           FuzzyAntecedents antecedents) {
  GaFuzzyImmSpec spec;
  spec.settings.sample_period = 1.0;
  spec.settings.sample_period = 1.0;
  spec.settings.measurement_sigma = 0.5;
  spec.settings.transition_stay = rng.uniform(0.8, 0.99);
  spec.settings.initial_first_probability = rng.uniform(0.2, 0.9);
  spec.antecedents = antecedents;
  const double scale = antecedents == FuzzyAntecedents::kResidual ? 0.5 : 1.5;
  for (int i = 0; i < levels; ++i) {
    spec.levels.push_back({std::string("level ").append(std::to_string(i)), 0.01,
                           random_fuzzy_table(rng, 1 + static_cast<int>(rng.below(6)), scale)});
  }
  return spec;
}

}  // namespace imm::testing
