#pragma once
/// The Monte Carlo loop every experiment shares: a fresh track per run, the same plots for every
/// filter, seed 000's normalized errors and the mean mode probabilities per scan.

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "imm/datasets/maneuver_scenario.hpp"
#include "imm/filters/tracker.hpp"

namespace imm::evaluation {

struct FilterOutcome {
  std::string name;
  int modes = 0;
  double zeta_p = 0.0, zeta_v = 0.0;
  double position_rmse = 0.0, velocity_rmse = 0.0;
  Eigen::VectorXd position_error, velocity_error;  ///< P_e(k), V_e(k)
  Eigen::MatrixXd mean_mode_probabilities;         ///< steps × modes, averaged over runs
  std::vector<std::string> mode_names;
  long rejected_steps = 0;  ///< plots the filter could not use
};

using FilterFactory = std::function<std::unique_ptr<TrackFilter>()>;
/// Called after every scan with an estimate (run, scan, the filter).
using StepObserver = std::function<void(std::size_t run, int scan, const TrackFilter& filter)>;

/// Runs `make_filter()` over every run of `data` (Cartesian plots) and scores it.
[[nodiscard]] FilterOutcome run_monte_carlo(const std::string& name,
                                            const FilterFactory& make_filter,
                                            const TrackOptions& options,
                                            const datasets::ManeuverScenario& scenario,
                                            const datasets::ScenarioData& data,
                                            const StepObserver& observer = {});

}  // namespace imm::evaluation
