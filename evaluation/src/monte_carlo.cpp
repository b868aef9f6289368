// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/monte_carlo.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "imm/evaluation/report.hpp"
#include "imm/models/measurement/polar_measurement.hpp"
#include "imm/trainer/normalized_errors.hpp"
#include "imm/trainer/ranks.hpp"

namespace imm::evaluation {

// seed 000's ζ with the runs weighted: HeadlineMetric::Form::kScanZeta.
Statistic FilterOutcome::zeta_p_statistic() const { return zeta_headline()[0].statistic(); }

Statistic FilterOutcome::zeta_v_statistic() const { return zeta_headline()[1].statistic(); }

std::vector<HeadlineMetric> FilterOutcome::zeta_headline() const {
  return {
      {"zeta_p", HeadlineMetric::Form::kScanZeta, run_position, run_position_plot, run_counted},
      {"zeta_v", HeadlineMetric::Form::kScanZeta, run_velocity, run_velocity_plot, run_counted}};
}

HeadlineMetric FilterOutcome::maneuver_position_rmse() const {
  const Eigen::MatrixXd counted = run_counted.cwiseProduct(run_maneuvering);
  return rms_metric("position_rmse_maneuvering", run_position.cwiseProduct(counted).rowwise().sum(),
                    counted.rowwise().sum());
}

std::vector<HeadlineMetric> FilterOutcome::plot_headline() const {
  const Eigen::Index runs = run_log_likelihood.rows();
  Eigen::VectorXd nll = Eigen::VectorXd::Zero(runs), squares = nll, plots = nll;
  for (Eigen::Index r = 0; r < runs; ++r) {
    for (Eigen::Index k = 0; k < run_log_likelihood.cols(); ++k) {
      const double l = run_log_likelihood(r, k);
      const double s = run_innovation_x(r, k) + run_innovation_y(r, k);
      if (!std::isfinite(l) || !std::isfinite(s)) continue;
      nll(r) -= l;
      squares(r) += s;
      plots(r) += 1.0;
    }
  }
  return {ratio_metric("predictive_nll", nll, plots),
          nees_log_ratio_metric("nis_log_ratio", run_nis, 2),
          rms_metric("innovation_rms", squares, plots)};
}

std::vector<HeadlineMetric> FilterOutcome::headline() const {
  if (!has_truth) return plot_headline();
  std::vector<HeadlineMetric> metrics = zeta_headline();
  metrics.push_back(nees_log_ratio_metric("position_nees_log_ratio", run_position_nees, 2));
  return metrics;
}

FilterOutcome run_monte_carlo(const std::string& name, const FilterFactory& make_filter,
                              const TrackOptions& options, const datasets::TrackSet& data,
                              const StepRecorder& recorder,
                              const Eigen::Vector2d& sensor_position) {
  const bool polar = options.measurement_kind == MeasurementKind::kPolar;
  // Where the filter's frame sits in the regime's: polar filters work around the sensor.
  const Eigen::Vector2d origin = polar ? sensor_position : Eigen::Vector2d::Zero();
  // A plot as a position in the regime's frame.
  auto plot_position = [&](const Eigen::MatrixXd& z, int k) -> Eigen::Vector2d {
    Eigen::Vector2d plot = z.row(k).transpose();
    if (!polar) return plot;
    return origin + polar_to_cartesian(plot, options.measurement_covariance).position;
  };
  if (std::abs(data.sample_period - options.sample_period) > 1e-12 * data.sample_period) {
    throw std::runtime_error("filter '" + name + "': sample period differs from the tracks'");
  }
  const int steps = data.scans;
  const double T = data.sample_period;
  const auto runs = static_cast<Eigen::Index>(data.tracks.size());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  FilterOutcome outcome;
  outcome.name = name;
  {
    const Tracker probe(make_filter(), options);
    outcome.modes = probe.mode_count();
    for (int j = 0; j < outcome.modes; ++j)
      outcome.mode_names.push_back(probe.filter().mode_name(j));
  }
  const int modes = outcome.modes;
  const int extra = recorder.record ? recorder.width : 0;
  // One run's terms: for every scan the squared errors (4), whether they counted (1: the scan has
  // an estimate and its truth), the position NEES and the NIS (2), whether the scan has an
  // estimate (1), the plot's predictive log-likelihood and the squared innovation's two
  // components (3: NaN without an update), the mode probabilities and the recorder's values; then
  // the rejected plots.
  constexpr int kEstimated = 7, kLogLikelihood = 8, kInnovation = 9;
  constexpr int kModes = 11;
  const std::ptrdiff_t per_scan = kModes + modes + extra;
  const auto width = static_cast<int>(steps * per_scan + 1);

  const std::vector<double> all = trainer::shared_items(
      static_cast<long>(runs), width, [&](long run, std::span<double> run_terms) {
        double* terms = run_terms.data();
        for (int k = 0; k < steps; ++k) {
          std::fill_n(terms + k * per_scan + kModes + modes, extra, nan);
        }
        const datasets::Track& track = data.tracks[static_cast<std::size_t>(run)];
        const Eigen::MatrixXd& z = track.plots;
        Tracker tracker(make_filter(), options);
        const int n = tracker.state_dimension();
        const int y = n / 2;
        Eigen::VectorXd mean(n), variance(n);
        for (int k = 0; k < steps; ++k) {
          const TrackStepResult result = tracker.process(k, z.row(k).transpose());
          if (result.event == TrackEvent::kRejected) terms[width - 1] += 1.0;
          if (!tracker.initialized() || k == 0) continue;
          tracker.state(mean, variance);
          double* scan = terms + k * per_scan;
          const bool updated = result.event == TrackEvent::kUpdated;
          scan[kEstimated] = 1.0;
          Eigen::Vector2d nu(nan, nan);
          Eigen::Matrix2d S;
          if (updated && !tracker.filter().innovation(nu, S)) nu.setConstant(nan);
          scan[kLogLikelihood] = updated ? tracker.filter().log_predictive_likelihood() : nan;
          scan[kInnovation] = nu(0) * nu(0);
          scan[kInnovation + 1] = nu(1) * nu(1);
          const Eigen::Vector2d p = datasets::position_at(track, k),
                                v = datasets::velocity_at(track, k);
          const Eigen::Vector2d plot = plot_position(z, k), before = plot_position(z, k - 1);
          // Truth-free scans (a recording without truth, or its gaps) count only their NIS.
          const bool truth =
              p.allFinite() && v.allFinite() && plot.allFinite() && before.allFinite();
          const trainer::StepConsistency consistency = trainer::step_consistency(
              tracker.filter(), truth ? Eigen::Vector2d(p - origin) : Eigen::Vector2d::Zero());
          scan[5] = truth ? consistency.position_nees : nan;
          scan[6] = updated ? consistency.nis : nan;
          if (truth) {
            const Eigen::Vector2d measured_velocity = (plot - before) / T;
            scan[0] = (p - origin - Eigen::Vector2d(mean(0), mean(y))).squaredNorm();
            scan[1] = (p - plot).squaredNorm();
            scan[2] = (v - Eigen::Vector2d(mean(1), mean(y + 1))).squaredNorm();
            scan[3] = (v - measured_velocity).squaredNorm();
            scan[4] = 1.0;
          }
          Eigen::Map<Eigen::VectorXd>(scan + kModes, modes) = tracker.mode_probabilities();
          if (extra > 0)
            recorder.record(tracker.filter(), std::span<double>(scan + kModes + modes, extra));
        }
      });

  // Every figure from the runs' terms, in run order.
  outcome.run_position = Eigen::MatrixXd::Zero(runs, steps);
  outcome.run_position_plot = outcome.run_position;
  outcome.run_velocity = outcome.run_position;
  outcome.run_velocity_plot = outcome.run_position;
  outcome.run_counted = outcome.run_position;
  outcome.run_position_nees = Eigen::MatrixXd::Constant(runs, steps, nan);
  outcome.run_nis = outcome.run_position_nees;
  outcome.run_log_likelihood = outcome.run_position_nees;
  outcome.run_innovation_x = outcome.run_position_nees;
  outcome.run_innovation_y = outcome.run_position_nees;
  outcome.has_truth = data.has_truth;
  outcome.run_maneuvering = Eigen::MatrixXd::Zero(runs, steps);
  for (Eigen::Index run = 0; run < runs; ++run) {
    const std::vector<bool>& maneuvering = data.tracks[static_cast<std::size_t>(run)].maneuvering;
    for (int k = 0; k < steps && k < static_cast<int>(maneuvering.size()); ++k) {
      outcome.run_maneuvering(run, k) = maneuvering[static_cast<std::size_t>(k)] ? 1.0 : 0.0;
    }
  }
  outcome.mean_mode_probabilities = Eigen::MatrixXd::Zero(steps, modes);
  Eigen::VectorXi probability_samples = Eigen::VectorXi::Zero(steps);
  outcome.recorded.assign(static_cast<std::size_t>(runs * steps * extra), nan);
  for (Eigen::Index run = 0; run < runs; ++run) {
    const double* terms = all.data() + run * width;
    outcome.rejected_steps += static_cast<long>(terms[width - 1]);
    for (int k = 0; k < steps; ++k) {
      const double* scan = terms + k * per_scan;
      if (scan[kEstimated] == 0.0) continue;
      if (scan[4] != 0.0) {
        outcome.run_position(run, k) = scan[0];
        outcome.run_position_plot(run, k) = scan[1];
        outcome.run_velocity(run, k) = scan[2];
        outcome.run_velocity_plot(run, k) = scan[3];
        outcome.run_counted(run, k) = 1.0;
        outcome.run_position_nees(run, k) = scan[5];
      }
      outcome.run_nis(run, k) = scan[6];
      outcome.run_log_likelihood(run, k) = scan[kLogLikelihood];
      outcome.run_innovation_x(run, k) = scan[kInnovation];
      outcome.run_innovation_y(run, k) = scan[kInnovation + 1];
      outcome.mean_mode_probabilities.row(k) +=
          Eigen::Map<const Eigen::RowVectorXd>(scan + kModes, modes);
      ++probability_samples(k);
      std::copy_n(scan + kModes + modes, extra,
                  outcome.recorded.begin() + (run * steps + k) * extra);
    }
  }
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
  outcome.position_consistency = summarize_consistency(outcome.run_position_nees, 2);
  outcome.nis_consistency = summarize_consistency(outcome.run_nis, 2);
  return outcome;
}

std::string consistency_table(const std::vector<FilterOutcome>& filters) {
  std::vector<FilterConsistency> rows;
  rows.reserve(filters.size());
  for (const FilterOutcome& f : filters) rows.push_back(f.consistency());
  return consistency_table(rows);
}

}  // namespace imm::evaluation
