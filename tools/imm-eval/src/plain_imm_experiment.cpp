#include "imm/evaluation/plain_imm_experiment.hpp"

#include "imm/datasets/dataset_file.hpp"
#include "imm/evaluation/normalized_errors.hpp"
#include "imm/filters/tracker.hpp"
#include "imm/io/plain_imm_file.hpp"

namespace imm::evaluation {
namespace {

// The IMM's mode j as a filter of its own.
PlainImmSpec single_mode(const PlainImmSpec& spec, std::size_t j) {
  PlainImmSpec single = spec;
  single.modes = {spec.modes[j]};
  single.transition = Eigen::MatrixXd::Ones(1, 1);
  single.initial_probabilities = Eigen::VectorXd::Ones(1);
  if (single.initialization.method == InitializationMethod::kExplicit &&
      single.mixing_dimension() != spec.mixing_dimension()) {
    // A CV mode alone lives in the 4-state space: keep its part of the explicit prior.
    const std::array<int, 4> indices{0, 1, 3, 4};
    Eigen::VectorXd state(4);
    Eigen::MatrixXd covariance(4, 4);
    for (int a = 0; a < 4; ++a) {
      state(a) = spec.initialization.state(indices[static_cast<std::size_t>(a)]);
      for (int b = 0; b < 4; ++b) {
        covariance(a, b) = spec.initialization.covariance(indices[static_cast<std::size_t>(a)],
                                                          indices[static_cast<std::size_t>(b)]);
      }
    }
    single.initialization.state = state;
    single.initialization.covariance = covariance;
  }
  return single;
}

FilterOutcome evaluate(const std::string& name, const PlainImmSpec& spec,
                       const datasets::ManeuverScenario& scenario,
                       const datasets::ScenarioData& data) {
  if (spec.measurement.kind != scenario.measurement.kind) {
    throw std::runtime_error(
        "filter '" + name + "' expects " + std::string(to_string(spec.measurement.kind)) +
        " measurements, the data set holds " + std::string(to_string(scenario.measurement.kind)));
  }
  const int steps = scenario.steps;
  const double T = scenario.sample_period;
  NormalizedErrors errors(steps);
  FilterOutcome outcome;
  outcome.name = name;
  outcome.modes = static_cast<int>(spec.modes.size());
  for (const auto& mode : spec.modes) outcome.mode_names.push_back(mode.name);
  outcome.mean_mode_probabilities = Eigen::MatrixXd::Zero(steps, outcome.modes);
  Eigen::VectorXi probability_samples = Eigen::VectorXi::Zero(steps);
  const int n = spec.mixing_dimension();
  const int y_index = n / 2;
  Eigen::VectorXd mean(n), variance(n);

  for (std::size_t run = 0; run < data.truth.size(); ++run) {
    const Eigen::MatrixXd& truth = data.truth[run];
    const Eigen::MatrixXd& z = data.measurements[run];
    PlainImmTracker tracker(spec);
    for (int k = 0; k < steps; ++k) {
      const TrackStepResult result = tracker.process(k, z.row(k).transpose());
      if (result.event == TrackEvent::kRejected) ++outcome.rejected_steps;
      if (!tracker.initialized() || k == 0) continue;
      tracker.state(mean, variance);
      const Eigen::Vector2d measured = z.row(k).transpose();
      const Eigen::Vector2d measured_velocity = (z.row(k) - z.row(k - 1)).transpose() / T;
      errors.add(k, Eigen::Vector2d(truth(k, 0), truth(k, 2)),
                 Eigen::Vector2d(mean(0), mean(y_index)), measured,
                 Eigen::Vector2d(truth(k, 1), truth(k, 3)),
                 Eigen::Vector2d(mean(1), mean(y_index + 1)), measured_velocity);
      outcome.mean_mode_probabilities.row(k) += tracker.mode_probabilities().transpose();
      ++probability_samples(k);
    }
  }
  for (int k = 0; k < steps; ++k) {
    if (probability_samples(k) > 0)
      outcome.mean_mode_probabilities.row(k) /= probability_samples(k);
    else
      outcome.mean_mode_probabilities.row(k).setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  outcome.position_error = errors.position();
  outcome.velocity_error = errors.velocity();
  outcome.zeta_p = errors.zeta_p();
  outcome.zeta_v = errors.zeta_v();
  outcome.position_rmse = errors.position_rmse();
  outcome.velocity_rmse = errors.velocity_rmse();
  return outcome;
}

}  // namespace

PlainImmExperimentResult run_plain_imm_experiment(const PlainImmExperimentOptions& options) {
  const PlainImmSpec spec = io::read_plain_imm(options.model);
  datasets::ManeuverScenario scenario;
  datasets::ScenarioData data;
  PlainImmExperimentResult result;
  if (options.data) {
    datasets::ScenarioDataset stored = datasets::read_scenario_dataset(*options.data);
    scenario = std::move(stored.scenario);
    data = std::move(stored.data);
    result.dataset_digest = stored.digest;
  } else {
    scenario = datasets::seed000_scenario();
    scenario.runs = options.runs;
    scenario.seed = options.seed;
    data = datasets::simulate(scenario);
    result.dataset_digest = datasets::digest(data);
  }
  if (std::abs(scenario.sample_period - spec.sample_period) > 1e-12) {
    throw std::runtime_error("the model's sample period differs from the data's");
  }
  result.scenario = scenario.name;
  result.runs = scenario.runs;
  result.steps = scenario.steps;
  result.seed = scenario.seed;
  result.filters.push_back(evaluate(options.model.stem().string(), spec, scenario, data));
  for (std::size_t j = 0; j < spec.modes.size() && spec.modes.size() > 1; ++j) {
    result.filters.push_back(
        evaluate("KF " + spec.modes[j].name, single_mode(spec, j), scenario, data));
  }
  return result;
}

}  // namespace imm::evaluation
