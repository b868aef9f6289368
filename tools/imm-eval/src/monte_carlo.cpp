#include "imm/evaluation/monte_carlo.hpp"

#include <limits>
#include <stdexcept>

#include "imm/evaluation/normalized_errors.hpp"

namespace imm::evaluation {

FilterOutcome run_monte_carlo(const std::string& name, const FilterFactory& make_filter,
                              const TrackOptions& options,
                              const datasets::ManeuverScenario& scenario,
                              const datasets::ScenarioData& data, const StepObserver& observer) {
  if (scenario.measurement.kind != MeasurementKind::kCartesian ||
      options.measurement_kind != MeasurementKind::kCartesian) {
    throw std::runtime_error("filter '" + name + "': the evaluation scores Cartesian plots");
  }
  if (std::abs(scenario.sample_period - options.sample_period) > 1e-12) {
    throw std::runtime_error("filter '" + name + "': sample period differs from the data's");
  }
  const int steps = scenario.steps;
  const double T = scenario.sample_period;
  NormalizedErrors errors(steps);
  FilterOutcome outcome;
  outcome.name = name;
  Eigen::VectorXi probability_samples = Eigen::VectorXi::Zero(steps);

  for (std::size_t run = 0; run < data.truth.size(); ++run) {
    const Eigen::MatrixXd& truth = data.truth[run];
    const Eigen::MatrixXd& z = data.measurements[run];
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
      const Eigen::Vector2d measured_velocity = (z.row(k) - z.row(k - 1)).transpose() / T;
      errors.add(k, Eigen::Vector2d(truth(k, 0), truth(k, 2)), Eigen::Vector2d(mean(0), mean(y)),
                 z.row(k).transpose(), Eigen::Vector2d(truth(k, 1), truth(k, 3)),
                 Eigen::Vector2d(mean(1), mean(y + 1)), measured_velocity);
      outcome.mean_mode_probabilities.row(k) += tracker.mode_probabilities().transpose();
      ++probability_samples(k);
      if (observer) observer(run, k, tracker.filter());
    }
  }
  for (int k = 0; k < steps; ++k) {
    if (probability_samples(k) > 0) {
      outcome.mean_mode_probabilities.row(k) /= probability_samples(k);
    } else {
      outcome.mean_mode_probabilities.row(k).setConstant(std::numeric_limits<double>::quiet_NaN());
    }
  }
  outcome.position_error = errors.position();
  outcome.velocity_error = errors.velocity();
  outcome.zeta_p = errors.zeta_p();
  outcome.zeta_v = errors.zeta_v();
  outcome.position_rmse = errors.position_rmse();
  outcome.velocity_rmse = errors.velocity_rmse();
  return outcome;
}

}  // namespace imm::evaluation
