#include "imm/evaluation/plain_imm_experiment.hpp"

#include "imm/datasets/dataset_file.hpp"
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
  return run_monte_carlo(
      name, [&] { return make_plain_imm_filter(spec); }, track_options(spec), scenario, data);
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
