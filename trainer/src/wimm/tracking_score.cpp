// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/wimm/tracking_score.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <stdexcept>

#include "imm/math/angle.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm/tracking/tracker.hpp"
#include "imm/trainer/normalized_errors.hpp"
#include "imm/trainer/ranks.hpp"

namespace imm::trainer::wimm {
namespace {

double mean_over(const Eigen::VectorXd& values, Eigen::Index first) {
  double sum = 0.0;
  int count = 0;
  for (Eigen::Index k = first; k < values.size(); ++k) {
    if (std::isfinite(values(k))) {
      sum += values(k);
      ++count;
    }
  }
  return count > 0 ? sum / count : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

int first_settled_scan(int scans) { return std::min(kFirstSettledScan, scans / 5); }

TrackingScore score_tracking(const WimmSpec& spec, const datasets::TrackSet& data,
                             const Eigen::Vector2d& sensor_position) {
  if (std::abs(spec.sample_period - data.sample_period) > 1e-12 * data.sample_period) {
    throw std::invalid_argument("the filter's sample period differs from the tracks'");
  }
  const int steps = data.scans;
  const int settled = first_settled_scan(steps);
  TrackingScore score;
  score.track_azimuth_settled =
      Eigen::VectorXd::Zero(static_cast<Eigen::Index>(data.tracks.size()));
  score.track_position_settled = score.track_azimuth_settled;
  Eigen::VectorXd azimuth_sq = Eigen::VectorXd::Zero(steps), position_sq = azimuth_sq;
  Eigen::VectorXd nees = azimuth_sq, fused = azimuth_sq;
  Eigen::VectorXi count = Eigen::VectorXi::Zero(steps);
  Eigen::MatrixXd mu = Eigen::MatrixXd::Zero(steps, 2);
  const std::array<int, 4> pv = {0, 1, 3, 4};  // x, vx, y, vy in the 6-state layout
  // One track's terms, per scan: counted, da², position error², NEES, fused, μ (2), position
  // NEES, NIS.
  constexpr std::ptrdiff_t kPerScan = 9;
  const auto width = static_cast<int>(steps * kPerScan);
  const auto tracks = static_cast<long>(data.tracks.size());
  const std::vector<double> all = shared_items(tracks, width, [&](long t, std::span<double> terms) {
    const datasets::Track& track = data.tracks[static_cast<std::size_t>(t)];
    auto owned = std::make_unique<WimmFilter>(spec);
    const WimmFilter& filter = *owned;
    Tracker tracker(std::move(owned), spec.track_options());
    const Eigen::MatrixXd& truth = track.truth;
    const Eigen::MatrixXd& z = track.plots;
    for (int k = 0; k < steps; ++k) {
      const TrackStepResult result = tracker.process(k, z.row(k).transpose());
      if (!tracker.initialized()) continue;
      const GaussianState<6>& estimate = filter.estimate();
      // The filter works around the sensor; the truth is in the regime's frame.
      const double x = truth(k, 0) - sensor_position(0), y = truth(k, 3) - sensor_position(1);
      const double dx = estimate.mean(0) - x, dy = estimate.mean(3) - y;
      const double da =
          wrap_angle(azimuth_of(estimate.mean(0), estimate.mean(3)) - azimuth_of(x, y));
      Eigen::Vector4d error(dx, estimate.mean(1) - truth(k, 1), dy, estimate.mean(4) - truth(k, 4));
      Eigen::Matrix4d P;
      for (int a = 0; a < 4; ++a) {
        for (int b = 0; b < 4; ++b) P(a, b) = estimate.covariance(pv[a], pv[b]);
      }
      const Eigen::LDLT<Eigen::Matrix4d> ldlt(P);
      double* scan = terms.data() + k * kPerScan;
      scan[0] = 1.0;
      scan[1] = da * da;
      scan[2] = dx * dx + dy * dy;
      scan[3] = error.dot(ldlt.solve(error));
      scan[4] = filter.fused() ? 1.0 : 0.0;
      Eigen::Map<Eigen::Vector2d>(scan + 5) = filter.mode_probabilities().head<2>();
      const StepConsistency consistency = step_consistency(filter, Eigen::Vector2d(x, y));
      scan[7] = consistency.position_nees;
      scan[8] = result.event == TrackEvent::kUpdated ? consistency.nis
                                                     : std::numeric_limits<double>::quiet_NaN();
    }
  });
  // The figures, summed in track order.
  score.run_position_nees = Eigen::MatrixXd::Constant(static_cast<Eigen::Index>(tracks), steps,
                                                      std::numeric_limits<double>::quiet_NaN());
  score.run_nis = score.run_position_nees;
  for (long t = 0; t < tracks; ++t) {
    const auto i = static_cast<Eigen::Index>(t);
    int settled_count = 0;
    for (int k = 0; k < steps; ++k) {
      const double* scan = all.data() + t * width + k * kPerScan;
      if (scan[0] == 0.0) continue;
      azimuth_sq(k) += scan[1];
      position_sq(k) += scan[2];
      nees(k) += scan[3];
      fused(k) += scan[4];
      mu.row(k) += Eigen::Map<const Eigen::RowVector2d>(scan + 5);
      score.run_position_nees(i, k) = scan[7];
      score.run_nis(i, k) = scan[8];
      ++count(k);
      if (k >= settled) {
        score.track_azimuth_settled(i) += scan[1];
        score.track_position_settled(i) += scan[2];
        ++settled_count;
      }
    }
    if (settled_count > 0) {
      score.track_azimuth_settled(i) /= settled_count;
      score.track_position_settled(i) /= settled_count;
    }
  }
  score.azimuth_rmse.resize(steps);
  score.position_rmse.resize(steps);
  score.mean_nees.resize(steps);
  score.fused_fraction.resize(steps);
  score.mean_mode_probabilities = mu;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int k = 0; k < steps; ++k) {
    const double n = count(k);
    score.azimuth_rmse(k) = n > 0 ? std::sqrt(azimuth_sq(k) / n) : nan;
    score.position_rmse(k) = n > 0 ? std::sqrt(position_sq(k) / n) : nan;
    score.mean_nees(k) = n > 0 ? nees(k) / n : nan;
    score.fused_fraction(k) = n > 0 ? fused(k) / n : nan;
    if (n > 0) {
      score.mean_mode_probabilities.row(k) /= n;
    } else {
      score.mean_mode_probabilities.row(k).setConstant(nan);
    }
  }
  score.azimuth = mean_over(score.azimuth_rmse, 0);
  score.azimuth_settled = mean_over(score.azimuth_rmse, settled);
  score.position = mean_over(score.position_rmse, 0);
  score.position_settled = mean_over(score.position_rmse, settled);
  score.nees_settled = mean_over(score.mean_nees, settled);
  return score;
}

PlotScore score_plots(const WimmSpec& spec, const datasets::TrackSet& data) {
  if (std::abs(spec.sample_period - data.sample_period) > 1e-12 * data.sample_period) {
    throw std::invalid_argument("the filter's sample period differs from the tracks'");
  }
  // One track's terms: Σ −log p, Σ normalized ν², updates.
  constexpr int kWidth = 3;
  const auto tracks = static_cast<long>(data.tracks.size());
  const Eigen::Vector2d sigma(spec.range_sigma, spec.azimuth_sigma);
  const std::vector<double> all =
      shared_items(tracks, kWidth, [&](long t, std::span<double> terms) {
        const datasets::Track& track = data.tracks[static_cast<std::size_t>(t)];
        auto owned = std::make_unique<WimmFilter>(spec);
        const WimmFilter& filter = *owned;
        Tracker tracker(std::move(owned), spec.track_options());
        Eigen::Vector2d nu;
        Eigen::Matrix2d S;
        for (Eigen::Index k = 0; k < track.plots.rows(); ++k) {
          if (tracker.process(k, track.plots.row(k).transpose()).event != TrackEvent::kUpdated) {
            continue;
          }
          terms[0] -= filter.log_predictive_likelihood();
          if (filter.innovation(nu, S)) terms[1] += nu.cwiseQuotient(sigma).squaredNorm();
          terms[2] += 1.0;
        }
      });
  double nll = 0.0, squares = 0.0, plots = 0.0;
  for (long t = 0; t < tracks; ++t) {
    nll += all[static_cast<std::size_t>(t * kWidth)];
    squares += all[static_cast<std::size_t>(t * kWidth + 1)];
    plots += all[static_cast<std::size_t>(t * kWidth + 2)];
  }
  PlotScore score;
  score.plots = static_cast<long>(plots);
  const double entropy = kLogTwoPiE + std::log(spec.range_sigma * spec.azimuth_sigma);
  score.excess_nll = nll / plots - entropy;
  score.innovation_rms = std::sqrt(squares / plots);
  constexpr double kWorst = std::numeric_limits<double>::max();
  if (!std::isfinite(score.excess_nll)) score.excess_nll = kWorst;
  if (!std::isfinite(score.innovation_rms)) score.innovation_rms = kWorst;
  return score;
}

}  // namespace imm::trainer::wimm
