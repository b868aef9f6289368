#include "imm/trainer/wimm/tracking_score.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "imm/math/angle.hpp"

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

TrackingScore score_tracking(const WimmSpec& spec, const datasets::ManeuverScenario& scenario,
                             const datasets::ScenarioData& data) {
  if (scenario.measurement.kind != MeasurementKind::kPolar) {
    throw std::invalid_argument("the weighted IMM is scored on polar plots");
  }
  const int steps = scenario.steps;
  Eigen::VectorXd azimuth_sq = Eigen::VectorXd::Zero(steps), position_sq = azimuth_sq;
  Eigen::VectorXd nees = azimuth_sq, fused = azimuth_sq;
  Eigen::VectorXi count = Eigen::VectorXi::Zero(steps);
  Eigen::MatrixXd mu = Eigen::MatrixXd::Zero(steps, 2);
  const std::array<int, 4> pv = {0, 1, 3, 4};  // x, vx, y, vy in the 6-state layout
  for (std::size_t run = 0; run < data.truth.size(); ++run) {
    auto owned = std::make_unique<WeightedImmFilter>(spec);
    const WeightedImmFilter& filter = *owned;
    Tracker tracker(std::move(owned), spec.track_options());
    const Eigen::MatrixXd& truth = data.truth[run];
    const Eigen::MatrixXd& z = data.measurements[run];
    for (int k = 0; k < steps; ++k) {
      (void)tracker.process(k, z.row(k).transpose());
      if (!tracker.initialized()) continue;
      const GaussianState<6>& estimate = filter.estimate();
      const double dx = estimate.mean(0) - truth(k, 0), dy = estimate.mean(3) - truth(k, 2);
      const double da = wrap_angle(azimuth_of(estimate.mean(0), estimate.mean(3)) -
                                   azimuth_of(truth(k, 0), truth(k, 2)));
      Eigen::Vector4d error(dx, estimate.mean(1) - truth(k, 1), dy, estimate.mean(4) - truth(k, 3));
      Eigen::Matrix4d P;
      for (int a = 0; a < 4; ++a) {
        for (int b = 0; b < 4; ++b) P(a, b) = estimate.covariance(pv[a], pv[b]);
      }
      const Eigen::LDLT<Eigen::Matrix4d> ldlt(P);
      azimuth_sq(k) += da * da;
      position_sq(k) += dx * dx + dy * dy;
      nees(k) += error.dot(ldlt.solve(error));
      fused(k) += filter.fused() ? 1.0 : 0.0;
      mu.row(k) += filter.mode_probabilities().head<2>().transpose();
      ++count(k);
    }
  }
  TrackingScore score;
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
  score.azimuth_settled = mean_over(score.azimuth_rmse, kFirstSettledScan);
  score.position = mean_over(score.position_rmse, 0);
  score.position_settled = mean_over(score.position_rmse, kFirstSettledScan);
  score.nees_settled = mean_over(score.mean_nees, kFirstSettledScan);
  return score;
}

}  // namespace imm::trainer::wimm
