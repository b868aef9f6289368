// SPDX-License-Identifier: Apache-2.0
#include "imm/datasets/sensor_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "imm/datasets/recorded.hpp"
#include "imm/filters/axis_cv_imm.hpp"
#include "imm/support/bounded_search.hpp"

namespace imm::datasets {
namespace {

// The axis's finite plots with their scans.
struct AxisPlots {
  std::vector<Eigen::Index> scans;
  std::vector<double> values;
};

AxisPlots axis_plots(const Track& track, Eigen::Index axis) {
  AxisPlots plots;
  for (Eigen::Index k = 0; k < track.plots.rows(); ++k) {
    if (!std::isfinite(track.plots(k, 0)) || !std::isfinite(track.plots(k, 1))) continue;
    plots.scans.push_back(k);
    plots.values.push_back(track.plots(k, axis));
  }
  return plots;
}

double median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto middle = values.begin() + static_cast<long>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

// MAD of the second differences of consecutive plots: for a CV target without manoeuvre they are
// z(k+1) − 2 z(k) + z(k−1) = e(k+1) − 2 e(k) + e(k−1), of variance 6 σ².
double robust_sigma(const TrackSet& set) {
  std::vector<double> d;
  for (const Track& track : set.tracks) {
    for (Eigen::Index axis = 0; axis < 2; ++axis) {
      for (Eigen::Index k = 1; k + 1 < track.plots.rows(); ++k) {
        const double v =
            track.plots(k + 1, axis) - 2.0 * track.plots(k, axis) + track.plots(k - 1, axis);
        if (std::isfinite(v)) d.push_back(v);
      }
    }
  }
  const double m = median(d);
  for (double& v : d) v = std::abs(v - m);
  return 1.482602218505602 * median(d) / std::sqrt(6.0);
}

}  // namespace

std::pair<double, long> axis_imm_log_likelihood(const TrackSet& set, const AxisImmModel& model) {
  AxisCvImmSpec spec;
  spec.settings.sample_period = model.sample_period;
  spec.settings.measurement_sigma = model.sigma;
  spec.settings.transition_stay = model.stay;
  spec.settings.initial_first_probability = 0.5;
  spec.process_noise = {model.quiet_noise, model.manoeuvre_noise};
  ImmEstimator<2, 1> imm = build_axis_cv_imm(spec);
  const double T = model.sample_period, r = model.sigma * model.sigma;
  double total = 0.0;
  long scored = 0;
  for (const Track& track : set.tracks) {
    for (Eigen::Index axis = 0; axis < 2; ++axis) {
      const AxisPlots plots = axis_plots(track, axis);
      if (plots.scans.size() < 3) continue;
      const double dt = static_cast<double>(plots.scans[1] - plots.scans[0]) * T;
      GaussianState<2> start;
      start.mean << plots.values[1], (plots.values[1] - plots.values[0]) / dt;
      start.covariance << r, r / dt, r / dt, 2.0 * r / (dt * dt);
      imm.initialize(start);
      for (std::size_t i = 2; i < plots.scans.size(); ++i) {
        for (Eigen::Index k = plots.scans[i - 1] + 1; k < plots.scans[i]; ++k) {
          if (imm.predict_only() != StepStatus::kOk) {
            return {-std::numeric_limits<double>::infinity(), scored};
          }
        }
        if (imm.step(Vector<1>(plots.values[i])) != StepStatus::kOk) {
          return {-std::numeric_limits<double>::infinity(), scored};
        }
        total += imm.log_predictive_likelihood();
        ++scored;
      }
    }
  }
  return {total, scored};
}

PlotSigmaFit fit_plot_sigma(const TrackSet& set) {
  PlotSigmaFit fit;
  fit.start_sigma = robust_sigma(set);
  if (!(fit.start_sigma > 0.0 && std::isfinite(fit.start_sigma))) {
    throw std::runtime_error("the plots do not vary: no σ can be learned from them");
  }
  const double T = set.sample_period;
  // q in units of the plots' σ² per T³ (a q T³ of σ² moves a target by about σ in a scan).
  const double scale = fit.start_sigma * fit.start_sigma / (T * T * T);
  auto model_of = [&](const std::vector<double>& x) {
    AxisImmModel m;
    m.sample_period = T;
    m.sigma = fit.start_sigma * std::exp(x[0]);
    m.quiet_noise = scale * std::exp(x[1]);
    m.manoeuvre_noise = m.quiet_noise * std::exp(x[2]);
    return m;
  };
  const support::SearchObjective nll = [&](const std::vector<double>& x) {
    return -axis_imm_log_likelihood(set, model_of(x)).first;
  };
  // log σ/σ₀ within [1/8, 4]; log q₁ over 10 decades; q₂/q₁ up to 10⁶.
  const std::vector<double> lower = {std::log(0.125), std::log(1e-8), 0.0};
  const std::vector<double> upper = {std::log(4.0), std::log(1e2), std::log(1e6)};
  support::SearchOptions options;
  options.grid_points = 5;
  options.polish_evaluations = 300;
  options.xtol_rel = 1e-6;
  const support::SearchResult best = support::grid_then_subplex(nll, lower, upper, options);
  fit.model = model_of(best.x);
  const auto [log_likelihood, plots] = axis_imm_log_likelihood(set, fit.model);
  fit.log_likelihood = log_likelihood;
  fit.plots = plots;
  return fit;
}

PolarSigmaFit fit_polar_sigma(const TrackSet& set) {
  // One coordinate as both axes of a set (the likelihood doubles; its maximum does not move).
  auto coordinate = [&](int column) {
    TrackSet one = set;
    for (Track& track : one.tracks) {
      Eigen::VectorXd z = track.plots.col(column);
      if (column == 1) {  // the azimuth unwrapped along the track, across its gaps
        double previous = std::numeric_limits<double>::quiet_NaN(), offset = 0.0;
        for (Eigen::Index k = 0; k < z.size(); ++k) {
          if (!std::isfinite(z(k))) continue;
          if (std::isfinite(previous)) {
            const double step = z(k) + offset - previous;
            offset -= 2.0 * std::numbers::pi * std::round(step / (2.0 * std::numbers::pi));
          }
          z(k) += offset;
          previous = z(k);
        }
      }
      track.plots.col(0) = z;
      track.plots.col(1) = z;
    }
    return fit_plot_sigma(one);
  };
  return {coordinate(0), coordinate(1)};
}

double estimate_plot_sigma(const Regime& regime) {
  if (!regime.recorded) throw std::logic_error("estimate_plot_sigma needs a recorded regime");
  return fit_plot_sigma(recorded_split(regime, Split::kTraining)).model.sigma;
}

}  // namespace imm::datasets
