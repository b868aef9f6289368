// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/fcm_imm_outcome.hpp"

#include <cmath>
#include <span>
#include <vector>

#include "imm/filters/fcm_imm.hpp"
#include "imm/trainer/normalized_errors.hpp"
#include "imm/trainer/ranks.hpp"

namespace imm::evaluation {
namespace {

constexpr int kFcmFirstScoredScan = 2;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace

FcmImmOutcome run_fcm_imm_filter(const std::string& name, const trainer::fcm::FilterFactory& make,
                                 const datasets::TrackSet& data, double sigma) {
  const int steps = data.scans;
  const double T = data.sample_period;
  const double r = sigma * sigma;
  const auto runs = static_cast<Eigen::Index>(data.tracks.size());
  FcmImmOutcome out;
  out.name = name;
  out.per_track = Eigen::MatrixXd::Zero(runs, 8);
  Eigen::VectorXd position = Eigen::VectorXd::Zero(steps), velocity = position, fraction = position;
  Eigen::VectorXi samples = Eigen::VectorXi::Zero(steps);
  double f_straight = 0.0, f_maneuver = 0.0;
  long n_straight = 0, n_maneuver = 0;
  bool is_fcm = false;
  out.first_run = Eigen::MatrixXd::Constant(steps, 4, kNaN);
  // One run's terms: whether its filter is an FCM-IMM; per scan: counted, dp, dv, maneuvering,
  // the FCM fraction, the estimate (4), failed, position NEES, NIS.
  constexpr std::ptrdiff_t kPerScan = 12;
  const auto width = static_cast<int>(1 + steps * kPerScan);
  const std::vector<double> all =
      trainer::shared_items(static_cast<long>(runs), width, [&](long run, std::span<double> terms) {
        const datasets::Track& track = data.tracks[static_cast<std::size_t>(run)];
        const Eigen::MatrixXd& z = track.plots;
        std::unique_ptr<TwoAxisFilter> filter = make();
        const auto* fx = dynamic_cast<const FcmImmAxisFilter*>(&filter->axis(0));
        const auto* fy = dynamic_cast<const FcmImmAxisFilter*>(&filter->axis(1));
        const bool fcm = fx != nullptr && fy != nullptr;
        terms[0] = fcm ? 1.0 : 0.0;
        Eigen::VectorXd mean(4);
        Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(4, 4);
        for (Eigen::Index axis = 0; axis < 2; ++axis) {
          mean.segment<2>(2 * axis) << z(1, axis), (z(1, axis) - z(0, axis)) / T;
          covariance.block<2, 2>(2 * axis, 2 * axis) << r, r / T, r / T, 2.0 * r / (T * T);
        }
        filter->initialize(mean, covariance);
        Eigen::VectorXd estimate(4), variance(4);
        for (int k = kFcmFirstScoredScan; k < steps; ++k) {
          double* scan = terms.data() + 1 + k * kPerScan;
          if (filter->step(z.row(k).transpose()) != StepStatus::kOk) {
            scan[9] = 1.0;
            continue;
          }
          filter->state(estimate, variance);
          const Eigen::Vector2d p = datasets::position_at(track, k),
                                v = datasets::velocity_at(track, k);
          scan[0] = 1.0;
          scan[1] = std::pow(estimate(0) - p(0), 2) + std::pow(estimate(2) - p(1), 2);
          scan[2] = std::pow(estimate(1) - v(0), 2) + std::pow(estimate(3) - v(1), 2);
          scan[3] = track.maneuvering[static_cast<std::size_t>(k)] ? 1.0 : 0.0;
          if (fcm) scan[4] = 0.5 * (fx->maneuver_fraction() + fy->maneuver_fraction());
          Eigen::Map<Eigen::Vector4d>(scan + 5) = estimate;
          const trainer::StepConsistency consistency = trainer::step_consistency(*filter, p);
          scan[10] = consistency.position_nees;
          scan[11] = consistency.nis;
        }
      });
  // The figures, summed in run order.
  Eigen::MatrixXd run_nees = Eigen::MatrixXd::Constant(runs, steps, kNaN), run_nis = run_nees;
  for (Eigen::Index run = 0; run < runs; ++run) {
    const double* terms = all.data() + run * width;
    is_fcm = terms[0] != 0.0;
    for (int k = kFcmFirstScoredScan; k < steps; ++k) {
      const double* scan = terms + 1 + k * kPerScan;
      if (scan[9] != 0.0) ++out.failed_steps;
      if (scan[0] == 0.0) continue;
      const double dp = scan[1], dv = scan[2];
      position(k) += dp;
      velocity(k) += dv;
      ++samples(k);
      const bool maneuvering = scan[3] != 0.0;
      run_nees(run, k) = scan[10];
      run_nis(run, k) = scan[11];
      out.per_track.row(run).head<4>() += Eigen::RowVector4d(dp, 1.0, dv, 1.0);
      if (maneuvering) out.per_track.row(run).tail<4>() += Eigen::RowVector4d(dp, 1.0, dv, 1.0);
      if (is_fcm) {
        const double f = scan[4];
        fraction(k) += f;
        (maneuvering ? f_maneuver : f_straight) += f;
        ++(maneuvering ? n_maneuver : n_straight);
      }
      if (run == 0) out.first_run.row(k) = Eigen::Map<const Eigen::RowVector4d>(scan + 5);
    }
  }
  out.position_rmse = Eigen::VectorXd::Constant(steps, kNaN);
  out.velocity_rmse = out.position_rmse;
  out.fraction = out.position_rmse;
  for (int k = kFcmFirstScoredScan; k < steps; ++k) {
    if (samples(k) == 0) continue;
    out.position_rmse(k) = std::sqrt(position(k) / samples(k));
    out.velocity_rmse(k) = std::sqrt(velocity(k) / samples(k));
    if (is_fcm) out.fraction(k) = fraction(k) / samples(k);
  }
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(runs);
  for (int f = 0; f < 4; ++f) out.figures[f] = out.statistic(f)(ones);
  out.position_nees = summarize_consistency(run_nees, 2);
  out.nis = summarize_consistency(run_nis, 2);
  out.run_position_nees = std::move(run_nees);
  if (is_fcm) {
    out.fraction_straight = n_straight > 0 ? f_straight / static_cast<double>(n_straight) : kNaN;
    out.fraction_maneuver = n_maneuver > 0 ? f_maneuver / static_cast<double>(n_maneuver) : kNaN;
  }
  return out;
}

}  // namespace imm::evaluation
