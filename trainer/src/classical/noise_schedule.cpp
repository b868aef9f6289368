// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/classical/noise_schedule.hpp"

#include <array>
#include <cmath>

#include "imm/support/bounded_search.hpp"

namespace imm::trainer::classical {
namespace {
constexpr std::array kDistanceCenters{0.75, 2.0, 3.5};
constexpr double kDistanceSpread = 0.6;
constexpr std::array kChangeCenters{-1.5, 0.0, 1.5};
constexpr double kChangeSpread = 0.8;
constexpr double kLog2Bound = 4.0;  // multipliers in [1/16, 16]
}  // namespace

FuzzyRuleTable schedule_table(const std::vector<double>& x) {
  std::vector<FuzzyRule> rules;
  rules.reserve(kScheduleRules);
  for (const double d : kDistanceCenters) {
    for (const double change : kChangeCenters) {
      const std::size_t l = rules.size();
      const double w = x.empty() ? 1.0 : std::exp2(x[l]);
      rules.push_back({d, kDistanceSpread, change, kChangeSpread, w});
    }
  }
  return FuzzyRuleTable(std::move(rules));
}

PlainImmSpec scheduled_spec(const PlainImmSpec& base, const std::vector<double>& x) {
  PlainImmSpec spec = base;
  for (std::size_t j = 0; j < spec.modes.size(); ++j) {
    const auto first = x.begin() + static_cast<std::ptrdiff_t>(j * kScheduleRules);
    spec.modes[j].noise_schedule =
        schedule_table(std::vector<double>(first, first + kScheduleRules));
  }
  return spec;
}

LearnedSchedule learn_noise_schedule(const PlainImmSpec& base, const datasets::TrackSet& training,
                                     const datasets::TrackSet& validation, int evaluations) {
  LearnedSchedule learned;
  const std::size_t n = base.modes.size() * kScheduleRules;
  const std::vector<double> lower(n, -kLog2Bound), upper(n, kLog2Bound), start(n, 0.0);
  const auto objective = [&](const std::vector<double>& x) {
    return score_classical(scheduled_spec(base, x), training).objective;
  };
  const support::SearchResult found =
      support::subplex(objective, start, lower, upper, evaluations, 1e-3);
  learned.evaluations = found.evaluations;
  const PlainImmSpec scheduled = scheduled_spec(base, found.x);
  learned.training_base = score_classical(base, training);
  learned.training = score_classical(scheduled, training);
  learned.validation_base = score_classical(base, validation);
  learned.validation = score_classical(scheduled, validation);
  learned.on = learned.validation.objective < learned.validation_base.objective &&
               learned.training.objective < learned.training_base.objective;
  learned.spec = learned.on ? scheduled : base;
  return learned;
}

}  // namespace imm::trainer::classical
