// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/baseline_tuning.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "imm/datasets/axis_trajectory.hpp"
#include "imm/support/bounded_search.hpp"
#include "imm/trainer/normalized_errors.hpp"

namespace imm::trainer {
namespace {

std::vector<double> exponentials(const std::vector<double>& logs) {
  std::vector<double> values;
  values.reserve(logs.size());
  for (double e : logs) values.push_back(std::pow(10.0, e));
  return values;
}

}  // namespace

namespace {

// Runs a fresh `make_filter()` over every trajectory of `sets`, two-point started from scans 0
// and 1, and calls `scan(filter, set, trajectory, k)` after each successful step k ≥ 2. False
// when a step fails (the rest is not run).
template <class Scan>
bool run_axis_filters(const AxisFilterFactory& make_filter, const std::vector<TrainingSet>& sets,
                      Scan&& scan) {
  for (const auto& set : sets) {
    for (const auto& t : set.trajectories) {
      auto filter = make_filter();
      filter->initialize(datasets::two_point_start(t, set.sample_period, set.measurement_variance));
      for (Eigen::Index k = 2; k < t.measurement.size(); ++k) {
        if (filter->step(t.measurement(k)) != StepStatus::kOk) return false;
        if (!scan(*filter, set, t, k)) return false;
      }
    }
  }
  return true;
}

}  // namespace

AxisZetas axis_zetas(const AxisFilterFactory& make_filter, const std::vector<TrainingSet>& sets) {
  constexpr double kFailed = std::numeric_limits<double>::infinity();
  if (!sets.empty() && sets.front().plots_only) {
    for (const auto& set : sets) {
      if (!set.plots_only) throw std::invalid_argument("axis_zetas: sets with and without truth");
    }
    double nll = 0.0;
    long plots = 0;
    const bool ran = run_axis_filters(
        make_filter, sets,
        [&](const AxisFilter& filter, const TrainingSet& set, const AxisTrajectory&, Eigen::Index) {
          nll -= filter.log_predictive_likelihood() + set.nll_floor();
          ++plots;
          return true;
        });
    if (!ran) return {kFailed, kFailed};
    return {plots > 0 && std::isfinite(nll) ? nll / static_cast<double>(plots) : kFailed, 0.0};
  }
  long steps = 0;
  for (const auto& set : sets) {
    for (const auto& t : set.trajectories) steps = std::max<long>(steps, t.measurement.size());
  }
  NormalizedErrors errors(static_cast<int>(steps));
  const bool ran = run_axis_filters(
      make_filter, sets,
      [&](const AxisFilter& filter, const TrainingSet& set, const AxisTrajectory& t,
          Eigen::Index k) {
        const auto& x = filter.estimate().mean;
        errors.add(static_cast<int>(k), {t.position(k), 0.0}, {x(0), 0.0}, {t.measurement(k), 0.0},
                   {t.velocity(k), 0.0}, {x(1), 0.0},
                   {(t.measurement(k) - t.measurement(k - 1)) / set.sample_period, 0.0});
        return true;
      });
  if (!ran) return {kFailed, kFailed};
  return {errors.zeta_p(), errors.zeta_v()};
}

double axis_innovation_rms(const AxisFilterFactory& make_filter,
                           const std::vector<TrainingSet>& sets) {
  double sum = 0.0;
  long plots = 0;
  const bool ran = run_axis_filters(
      make_filter, sets,
      [&](const AxisFilter& filter, const TrainingSet& set, const AxisTrajectory&, Eigen::Index) {
        double nu = 0.0, variance = 0.0;
        if (!filter.innovation(nu, variance)) return false;
        sum += nu * nu / set.measurement_variance;
        ++plots;
        return true;
      });
  return ran && plots > 0 ? std::sqrt(sum / static_cast<double>(plots))
                          : std::numeric_limits<double>::infinity();
}

double axis_score(const AxisFilterFactory& make_filter, const std::vector<TrainingSet>& sets) {
  const AxisZetas zetas = axis_zetas(make_filter, sets);
  return zetas.position + zetas.velocity;
}

Tuned<AimmSpec> tune_aimm(const AimmSpec& base, const std::vector<TrainingSet>& sets, double a,
                          int max_intervals) {
  Tuned<AimmSpec> best;
  best.score = std::numeric_limits<double>::infinity();
  for (int n = 1; n <= max_intervals; ++n) {
    auto score = [&](const std::vector<double>& log_epsilon) {
      AimmSpec spec = base;
      spec.intervals.clear();
      for (double e : log_epsilon) spec.intervals.push_back(std::pow(10.0, e));
      return axis_score([&] { return std::make_unique<AimmAxisFilter>(spec); }, sets);
    };
    const support::SearchResult result =
        support::grid_then_subplex(score, std::vector<double>(n, std::log10(0.01 * a)),
                                   std::vector<double>(n, std::log10(3.0 * a)),
                                   {.grid_points = n == 1 ? 16 : 10,
                                    .polish_evaluations = 60,
                                    .ordered = true,
                                    .xtol_abs = 1e-3});
    best.evaluations += result.evaluations;
    if (result.value < best.score) {
      best.score = result.value;
      best.spec = base;
      best.spec.intervals.clear();
      for (double e : result.x) best.spec.intervals.push_back(std::pow(10.0, e));
    }
  }
  return best;
}

Tuned<AxisCvImmSpec> tune_axis_cv_imm(const AxisCvImmSpec& base,
                                      const std::vector<TrainingSet>& sets, double a, int levels,
                                      TransitionTuning transitions) {
  auto score_of = [&](const AxisCvImmSpec& spec) {
    return axis_score([&] { return std::make_unique<ImmAxisFilter>(build_axis_cv_imm(spec)); },
                      sets);
  };
  auto score = [&](const std::vector<double>& log_q) {
    AxisCvImmSpec spec = base;
    spec.process_noise = exponentials(log_q);
    return score_of(spec);
  };
  const double log_low = std::log10(1e-8 * a * a), log_high = std::log10(10.0 * a * a);
  const support::SearchResult result = support::grid_then_subplex(
      score, std::vector<double>(levels, log_low), std::vector<double>(levels, log_high),
      {.grid_points = 8, .polish_evaluations = 150, .ordered = true, .xtol_abs = 1e-3});
  Tuned<AxisCvImmSpec> tuned;
  tuned.spec = base;
  tuned.spec.process_noise = exponentials(result.x);
  tuned.score = result.value;
  tuned.evaluations = result.evaluations;
  if (transitions == TransitionTuning::kFixed) return tuned;

  // The levels and log10(1 − p_jj) together, from the levels' optimum at the base's p_jj.
  auto joint = [&](const std::vector<double>& x) {
    AxisCvImmSpec spec = base;
    spec.process_noise = exponentials({x.begin(), x.end() - 1});
    spec.settings.transition_stay = 1.0 - std::pow(10.0, x.back());
    return score_of(spec);
  };
  std::vector<double> x0 = result.x, lower(levels, log_low), upper(levels, log_high);
  x0.push_back(
      std::clamp(std::log10(1.0 - base.settings.transition_stay), kLogLeaveLow, kLogLeaveHigh));
  lower.push_back(kLogLeaveLow);
  upper.push_back(kLogLeaveHigh);
  const support::SearchResult refined = support::subplex(joint, x0, lower, upper, 150, 1e-4);
  tuned.evaluations += refined.evaluations;
  if (refined.value < tuned.score) {
    tuned.score = refined.value;
    tuned.spec.process_noise = exponentials({refined.x.begin(), refined.x.end() - 1});
    tuned.spec.settings.transition_stay = 1.0 - std::pow(10.0, refined.x.back());
  }
  return tuned;
}

Tuned<AxisCvImmSpec> tune_imm_baseline(AxisImmSettings settings,
                                       const std::vector<TrainingSet>& sets, double a) {
  settings.transition_stay = AxisImmSettings{}.transition_stay;
  AxisCvImmSpec base;
  base.settings = settings;
  return tune_axis_cv_imm(base, sets, a, 3, TransitionTuning::kJointly);
}

}  // namespace imm::trainer
