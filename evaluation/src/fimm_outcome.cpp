// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/fimm_outcome.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <vector>

#include "imm/trainer/normalized_errors.hpp"
#include "imm/trainer/ranks.hpp"

namespace imm::evaluation {
namespace {

constexpr int kFimmFirstScoredScan = 2;

// dη_m/dη of the true sensor at a position (central differences).
double range_slope(const datasets::Sensor& sensor, const Eigen::Vector2d& p) {
  const double h = 1e-4 * std::max(1.0, std::abs(p(1)));
  return (sensor.response({p(0), p(1) + h})(1) - sensor.response({p(0), p(1) - h})(1)) / (2.0 * h);
}

}  // namespace

FimmOutcome run_fimm_filter(const std::function<std::unique_ptr<FimmFilter>()>& make,
                            const datasets::TrackSet& data, const datasets::Sensor& sensor,
                            double r, double acceleration_variance) {
  FimmOutcome out;
  const Eigen::Index steps = data.scans;
  const double T = data.sample_period;
  const auto runs = static_cast<Eigen::Index>(data.tracks.size());
  out.per_track = Eigen::MatrixXd::Zero(runs, 2);
  Eigen::VectorXd scan_sum = Eigen::VectorXd::Zero(steps), scan_count = scan_sum;
  out.first_run = Eigen::MatrixXd::Constant(steps, 2, std::numeric_limits<double>::quiet_NaN());
  // One run's terms, per scan: counted, e², NEES, outside the sensor box, in the flat part, the
  // estimate (ξ̂, η̂), failed, NIS.
  constexpr std::ptrdiff_t kPerScan = 9;
  const auto width = static_cast<int>(steps * kPerScan);
  const std::vector<double> all =
      trainer::shared_items(static_cast<long>(runs), width, [&](long run, std::span<double> terms) {
        const datasets::Track& track = data.tracks[static_cast<std::size_t>(run)];
        const Eigen::MatrixXd& z = track.plots;
        std::unique_ptr<FimmFilter> filter = make();
        Eigen::VectorXd mean = Eigen::VectorXd::Zero(6);
        Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(6, 6);
        for (Eigen::Index axis = 0; axis < 2; ++axis) {
          const Eigen::Index p = 3 * axis;
          mean(p) = z(1, axis);
          mean(p + 1) = (z(1, axis) - z(0, axis)) / T;
          covariance.block<3, 3>(p, p) << r, r / T, 0.0, r / T, 2.0 * r / (T * T), 0.0, 0.0, 0.0,
              acceleration_variance;
        }
        filter->initialize(mean, covariance);
        for (Eigen::Index k = kFimmFirstScoredScan; k < steps; ++k) {
          double* scan = terms.data() + k * kPerScan;
          if (filter->step(z.row(k).transpose()) != StepStatus::kOk) {
            scan[7] = 1.0;
            continue;
          }
          const GaussianState<6>& x = filter->estimate();
          const Eigen::Vector2d truth = datasets::position_at(track, k);
          const Eigen::Vector2d error(x.mean(0) - truth(0), x.mean(3) - truth(1));
          const trainer::StepConsistency consistency = trainer::step_consistency(*filter, truth);
          scan[0] = 1.0;
          scan[1] = error.squaredNorm();
          scan[2] = consistency.position_nees;
          scan[8] = consistency.nis;
          scan[3] = filter->outside_sensor_box() ? 1.0 : 0.0;
          scan[4] = range_slope(sensor, truth) < kFlatSlope ? 1.0 : 0.0;
          scan[5] = x.mean(0);
          scan[6] = x.mean(3);
        }
      });
  // The figures, summed in run order.
  double nees = 0.0, flat[2] = {}, steep[2] = {};
  long samples = 0, outside = 0;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Eigen::MatrixXd run_nees = Eigen::MatrixXd::Constant(runs, steps, nan), run_nis = run_nees;
  for (Eigen::Index run = 0; run < runs; ++run) {
    for (Eigen::Index k = kFimmFirstScoredScan; k < steps; ++k) {
      const double* scan = all.data() + run * width + k * kPerScan;
      if (scan[7] != 0.0) ++out.failed_steps;
      if (scan[0] == 0.0) continue;
      const double e2 = scan[1];
      out.per_track.row(run) += Eigen::RowVector2d(e2, 1.0);
      scan_sum(k) += e2;
      scan_count(k) += 1.0;
      double* bucket = scan[4] != 0.0 ? flat : steep;
      bucket[0] += e2;
      bucket[1] += 1.0;
      nees += scan[2];
      run_nees(run, k) = scan[2];
      run_nis(run, k) = scan[8];
      outside += scan[3] != 0.0 ? 1 : 0;
      ++samples;
      if (run == 0) out.first_run.row(k) << scan[5], scan[6];
    }
  }
  const double n = std::max<double>(1.0, static_cast<double>(samples));
  out.position_nees = summarize_consistency(run_nees, 2);
  out.nis = summarize_consistency(run_nis, 2);
  out.run_position_nees = std::move(run_nees);
  out.mse = out.per_track.col(0).sum() / n;
  out.nees = nees / n;
  out.clamped = static_cast<double>(outside) / n;
  out.mse_flat = flat[1] > 0.0 ? flat[0] / flat[1] : nan;
  out.mse_steep = steep[1] > 0.0 ? steep[0] / steep[1] : nan;
  out.scan_mse = (scan_sum.array() / scan_count.array()).matrix();
  for (Eigen::Index k = 0; k < steps; ++k) {
    if (scan_count(k) == 0.0) out.scan_mse(k) = nan;
  }
  return out;
}

}  // namespace imm::evaluation
