// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The Monte Carlo loop of the Cartesian experiments: a fresh filter per test track, the same plots
/// for every filter, seed 000's normalized errors and the mean mode probabilities per scan. Each
/// run's squared errors are kept, so that a comparison's uncertainty can be bootstrapped over runs.

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "imm/datasets/track.hpp"
#include "imm/evaluation/consistency.hpp"
#include "imm/evaluation/headline.hpp"
#include "imm/evaluation/uncertainty.hpp"
#include "imm/tracking/tracker.hpp"

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
  /// runs × scans × StepRecorder::width, run-major: what the recorder took (NaN where a scan has
  /// no estimate).
  std::vector<double> recorded;
  /// runs × scans: ‖p − p̂‖², ‖p − z‖², ‖v − v̂‖², ‖v − v̄‖² (0 where a run has no estimate), and
  /// 1 where it has one.
  Eigen::MatrixXd run_position, run_position_plot, run_velocity, run_velocity_plot, run_counted;
  /// runs × scans: the position NEES (x − x̂)ᵀ P⁻¹ (x − x̂) over the position block (NaN where a
  /// run has no estimate), and its summary against the χ² bounds.
  Eigen::MatrixXd run_position_nees;
  /// runs × scans: the NIS of every update (NaN where a run has none: before the track starts,
  /// a rejected plot).
  Eigen::MatrixXd run_nis;
  /// runs × scans, NaN where a run has no update: the plot's predictive log-likelihood
  /// (TrackFilter::log_predictive_likelihood) and the squares of its innovation's two components
  /// (in the filter's plot coordinates) — what a recorded regime without truth is scored by.
  Eigen::MatrixXd run_log_likelihood, run_innovation_x, run_innovation_y;
  /// runs × scans: 1 where the truth manoeuvres (a commanded acceleration or a turn acts on the
  /// transition that starts at the scan, datasets::Track::maneuvering), 0 elsewhere.
  Eigen::MatrixXd run_maneuvering;
  /// Whether the tracks had their truth (the errors above are all zero without it).
  bool has_truth = true;
  ConsistencySummary position_consistency;
  ConsistencySummary nis_consistency;

  /// The name with both summaries, for consistency_table.
  [[nodiscard]] FilterConsistency consistency() const {
    return {name, position_consistency, nis_consistency};
  }

  /// ζ_p and ζ_v with the runs weighted (all ones: the figures above), for the bootstrap.
  [[nodiscard]] Statistic zeta_p_statistic() const;
  [[nodiscard]] Statistic zeta_v_statistic() const;
  /// ζ_p and ζ_v as headline metrics (their per-run, per-scan terms).
  [[nodiscard]] std::vector<HeadlineMetric> zeta_headline() const;
  /// ζ_p, ζ_v and the position consistency (`position_nees_log_ratio`: the mean over runs of
  /// nees_log_ratio, lower is better) as headline metrics: what the regression gate compares.
  /// Without truth, plot_headline().
  [[nodiscard]] std::vector<HeadlineMetric> headline() const;
  /// The position RMSE over the scans where the truth manoeuvres (`position_rmse_maneuvering`,
  /// lengths in the regime's unit): where a filter's motion models are put to the test.
  [[nodiscard]] HeadlineMetric maneuver_position_rmse() const;
  /// What needs no truth, each lower-is-better: `predictive_nll` (−log p(z | Z^(k−1)) per plot),
  /// `nis_log_ratio` (the NIS's consistency, as position_nees_log_ratio) and `innovation_rms`
  /// (√ of the mean ‖ν‖² per plot, in the plot's coordinates).
  [[nodiscard]] std::vector<HeadlineMetric> plot_headline() const;
};

using FilterFactory = std::function<std::unique_ptr<TrackFilter>()>;

/// Values an experiment takes from the filter after every scan with an estimate: `width` of them,
/// written by `record` into its span. They come back in FilterOutcome::recorded.
struct StepRecorder {
  int width = 0;
  std::function<void(const TrackFilter& filter, std::span<double> values)> record;
};

/// consistency_table (consistency.hpp) of the filters' outcomes.
[[nodiscard]] std::string consistency_table(const std::vector<FilterOutcome>& filters);

/// Runs `make_filter()` over every track of `data` (Cartesian plots) and scores it.
///
/// The runs are spread over the job's ranks (trainer/ranks.hpp): each rank runs its share and
/// keeps every run's per-scan terms; the terms are exchanged whole and every figure is then
/// summed in run order, so the outcome is the same to the bit at any rank count.
///
/// Polar plots (range, azimuth around `sensor_position`, the regime's sensor): the filter works
/// around the sensor, so its estimate is shifted by the sensor's position before it is scored,
/// and ζ's raw-plot terms use the plots converted to Cartesian positions (and their differences
/// over T for the measured velocity).
[[nodiscard]] FilterOutcome run_monte_carlo(
    const std::string& name, const FilterFactory& make_filter, const TrackOptions& options,
    const datasets::TrackSet& data, const StepRecorder& recorder = {},
    const Eigen::Vector2d& sensor_position = Eigen::Vector2d::Zero());

}  // namespace imm::evaluation
