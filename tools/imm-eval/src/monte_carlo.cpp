// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/monte_carlo.hpp"

#include <limits>
#include <stdexcept>

namespace imm::evaluation {

// seed 000's ζ with the runs weighted: HeadlineMetric::Form::kScanZeta.
Statistic FilterOutcome::zeta_p_statistic() const { return zeta_headline()[0].statistic(); }

Statistic FilterOutcome::zeta_v_statistic() const { return zeta_headline()[1].statistic(); }

std::vector<HeadlineMetric> FilterOutcome::zeta_headline() const {
  return {
      {"zeta_p", HeadlineMetric::Form::kScanZeta, run_position, run_position_plot, run_counted},
      {"zeta_v", HeadlineMetric::Form::kScanZeta, run_velocity, run_velocity_plot, run_counted}};
}

FilterOutcome run_monte_carlo(const std::string& name, const FilterFactory& make_filter,
                              const TrackOptions& options, const datasets::TrackSet& data,
                              const StepObserver& observer) {
  if (options.measurement_kind != MeasurementKind::kCartesian) {
    throw std::runtime_error("filter '" + name + "': the evaluation scores Cartesian plots");
  }
  if (std::abs(data.sample_period - options.sample_period) > 1e-12 * data.sample_period) {
    throw std::runtime_error("filter '" + name + "': sample period differs from the tracks'");
  }
  const int steps = data.scans;
  const double T = data.sample_period;
  const auto runs = static_cast<Eigen::Index>(data.tracks.size());
  FilterOutcome outcome;
  outcome.name = name;
  outcome.run_position = Eigen::MatrixXd::Zero(runs, steps);
  outcome.run_position_plot = outcome.run_position;
  outcome.run_velocity = outcome.run_position;
  outcome.run_velocity_plot = outcome.run_position;
  outcome.run_counted = outcome.run_position;
  Eigen::VectorXi probability_samples = Eigen::VectorXi::Zero(steps);

  for (Eigen::Index run = 0; run < runs; ++run) {
    const datasets::Track& track = data.tracks[static_cast<std::size_t>(run)];
    const Eigen::MatrixXd& z = track.plots;
    Tracker tracker(make_filter(), options);
    if (run == 0) {
      outcome.modes = tracker.mode_count();
      for (int j = 0; j < outcome.modes; ++j)
        outcome.mode_names.push_back(tracker.filter().mode_name(j));
      outcome.mean_mode_probabilities = Eigen::MatrixXd::Zero(steps, outcome.modes);
    }
    const int n = tracker.state_dimension();
    const int y = n / 2;
    Eigen::VectorXd mean(n), variance(n);
    for (int k = 0; k < steps; ++k) {
      const TrackStepResult result = tracker.process(k, z.row(k).transpose());
      if (result.event == TrackEvent::kRejected) ++outcome.rejected_steps;
      if (!tracker.initialized() || k == 0) continue;
      tracker.state(mean, variance);
      const Eigen::Vector2d p = datasets::position_at(track, k),
                            v = datasets::velocity_at(track, k);
      const Eigen::Vector2d plot = z.row(k).transpose();
      const Eigen::Vector2d measured_velocity = (z.row(k) - z.row(k - 1)).transpose() / T;
      outcome.run_position(run, k) = (p - Eigen::Vector2d(mean(0), mean(y))).squaredNorm();
      outcome.run_position_plot(run, k) = (p - plot).squaredNorm();
      outcome.run_velocity(run, k) = (v - Eigen::Vector2d(mean(1), mean(y + 1))).squaredNorm();
      outcome.run_velocity_plot(run, k) = (v - measured_velocity).squaredNorm();
      outcome.run_counted(run, k) = 1.0;
      outcome.mean_mode_probabilities.row(k) += tracker.mode_probabilities().transpose();
      ++probability_samples(k);
      if (observer) observer(static_cast<std::size_t>(run), k, tracker.filter());
    }
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int k = 0; k < steps; ++k) {
    if (probability_samples(k) > 0) {
      outcome.mean_mode_probabilities.row(k) /= probability_samples(k);
    } else {
      outcome.mean_mode_probabilities.row(k).setConstant(nan);
    }
  }
  const Eigen::RowVectorXd pe = outcome.run_position.colwise().sum(),
                           pm = outcome.run_position_plot.colwise().sum(),
                           ve = outcome.run_velocity.colwise().sum(),
                           vm = outcome.run_velocity_plot.colwise().sum(),
                           count = outcome.run_counted.colwise().sum();
  outcome.position_error.resize(steps);
  outcome.velocity_error.resize(steps);
  for (int k = 0; k < steps; ++k) {
    outcome.position_error(k) = count(k) > 0 && pm(k) > 0 ? std::sqrt(pe(k) / pm(k)) : nan;
    outcome.velocity_error(k) = count(k) > 0 && vm(k) > 0 ? std::sqrt(ve(k) / vm(k)) : nan;
  }
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(runs);
  outcome.zeta_p = outcome.zeta_p_statistic()(ones);
  outcome.zeta_v = outcome.zeta_v_statistic()(ones);
  const double samples = std::max(1.0, count.sum());
  outcome.position_rmse = std::sqrt(pe.sum() / samples);
  outcome.velocity_rmse = std::sqrt(ve.sum() / samples);
  return outcome;
}

}  // namespace imm::evaluation
