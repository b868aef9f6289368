// SPDX-License-Identifier: Apache-2.0
// The GA-fuzzy IMM of seed 000 §3.2: per axis an IMM of fuzzy-noise Kalman modes.
#include "imm/filters/ga_fuzzy_imm.hpp"

#include <array>

#include "imm/core/enum_names.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/filters/fuzzy_noise_filter.hpp"

namespace imm {
namespace {
constexpr std::array kAntecedentNames{
    EnumName<FuzzyAntecedents>{FuzzyAntecedents::kResidual, "residual"},
    EnumName<FuzzyAntecedents>{FuzzyAntecedents::kNormalizedInnovation, "normalized_innovation"}};
}  // namespace

std::string_view to_string(FuzzyAntecedents antecedents) {
  return name_of(kAntecedentNames, antecedents);
}

FuzzyAntecedents fuzzy_antecedents_from(std::string_view name, const std::string& field) {
  return value_named(kAntecedentNames, name, field, "antecedents");
}

void GaFuzzyImmSpec::validate() const {
  settings.validate();
  if (levels.empty() || levels.size() > 8) throw InvalidParameter("levels", "need 1 to 8 levels");
  for (std::size_t i = 0; i < levels.size(); ++i) {
    const std::string field = "levels[" + std::to_string(i) + "]";
    if (levels[i].name.empty()) throw InvalidParameter(field + ".name", "must not be empty");
    limits::require_in(levels[i].maneuver_level, limits::kAcceleration, field + ".maneuver_level");
    if (levels[i].table.size() == 0) throw InvalidParameter(field + ".rules", "table is empty");
  }
}

ImmEstimator<2, 1> build_ga_fuzzy_axis_imm(const GaFuzzyImmSpec& spec) {
  spec.validate();
  const AxisImmSettings& s = spec.settings;
  std::vector<std::unique_ptr<ImmMode<2, 1>>> modes;
  modes.reserve(spec.levels.size());
  for (const FuzzyLevel& level : spec.levels) {
    modes.push_back(std::make_unique<FuzzyNoiseMode>(
        level.name, FuzzyNoiseFilter(level.table, s.sample_period,
                                     s.measurement_sigma * s.measurement_sigma, spec.antecedents)));
  }
  const int n = static_cast<int>(modes.size());
  return {std::move(modes), s.transition(n), s.initial_probabilities(n)};
}

std::unique_ptr<TwoAxisFilter> make_ga_fuzzy_imm_filter(const GaFuzzyImmSpec& spec) {
  return std::make_unique<TwoAxisFilter>(
      std::make_unique<ImmAxisFilter>(build_ga_fuzzy_axis_imm(spec)),
      std::make_unique<ImmAxisFilter>(build_ga_fuzzy_axis_imm(spec)));
}

}  // namespace imm
