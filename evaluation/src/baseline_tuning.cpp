// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/baseline_tuning.hpp"

#include <cmath>
#include <limits>

#include "imm/evaluation/normalized_errors.hpp"
#include "imm/trainer/bounded_search.hpp"

namespace imm::evaluation {
namespace {

using trainer::grid_then_subplex;
using trainer::SearchOptions;
using trainer::SearchResult;

}  // namespace

double axis_score(const AxisFilterFactory& make_filter,
                  const std::vector<trainer::ga::TrainingSet>& sets) {
  long steps = 0;
  for (const auto& set : sets) {
    for (const auto& t : set.trajectories) steps = std::max<long>(steps, t.measurement.size());
  }
  NormalizedErrors errors(static_cast<int>(steps));
  for (const auto& set : sets) {
    const double T = set.sample_period, r = set.measurement_variance;
    for (const auto& t : set.trajectories) {
      auto filter = make_filter();
      GaussianState<2> start;
      start.mean << t.measurement(1), (t.measurement(1) - t.measurement(0)) / T;
      start.covariance << r, r / T, r / T, 2.0 * r / (T * T);
      filter->initialize(start);
      for (Eigen::Index k = 2; k < t.measurement.size(); ++k) {
        if (filter->step(t.measurement(k)) != StepStatus::kOk) {
          return std::numeric_limits<double>::infinity();
        }
        const auto& x = filter->estimate().mean;
        errors.add(static_cast<int>(k), {t.position(k), 0.0}, {x(0), 0.0}, {t.measurement(k), 0.0},
                   {t.velocity(k), 0.0}, {x(1), 0.0},
                   {(t.measurement(k) - t.measurement(k - 1)) / T, 0.0});
      }
    }
  }
  return errors.zeta_p() + errors.zeta_v();
}

Tuned<AimmSpec> tune_aimm(const AimmSpec& base, const std::vector<trainer::ga::TrainingSet>& sets,
                          double a, int max_intervals) {
  Tuned<AimmSpec> best;
  best.score = std::numeric_limits<double>::infinity();
  for (int n = 1; n <= max_intervals; ++n) {
    auto score = [&](const std::vector<double>& log_epsilon) {
      AimmSpec spec = base;
      spec.intervals.clear();
      for (double e : log_epsilon) spec.intervals.push_back(std::pow(10.0, e));
      return axis_score([&] { return std::make_unique<AimmAxisFilter>(spec); }, sets);
    };
    const SearchResult result =
        grid_then_subplex(score, std::vector<double>(n, std::log10(0.01 * a)),
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
                                      const std::vector<trainer::ga::TrainingSet>& sets, double a,
                                      int levels) {
  auto score = [&](const std::vector<double>& log_q) {
    AxisCvImmSpec spec = base;
    spec.process_noise.clear();
    for (double e : log_q) spec.process_noise.push_back(std::pow(10.0, e));
    return axis_score([&] { return std::make_unique<ImmAxisFilter>(build_axis_cv_imm(spec)); },
                      sets);
  };
  const SearchResult result = grid_then_subplex(
      score, std::vector<double>(levels, std::log10(1e-8 * a * a)),
      std::vector<double>(levels, std::log10(10.0 * a * a)),
      {.grid_points = 8, .polish_evaluations = 150, .ordered = true, .xtol_abs = 1e-3});
  Tuned<AxisCvImmSpec> tuned;
  tuned.spec = base;
  tuned.spec.process_noise.clear();
  for (double e : result.x) tuned.spec.process_noise.push_back(std::pow(10.0, e));
  tuned.score = result.value;
  tuned.evaluations = result.evaluations;
  return tuned;
}

}  // namespace imm::evaluation
