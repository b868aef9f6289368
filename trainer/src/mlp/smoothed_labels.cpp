// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/mlp/smoothed_labels.hpp"

#include <Eigen/LU>
#include <stdexcept>
#include <vector>

namespace imm::trainer::mlp {
namespace {

// One axis: smoothed positions, velocities and accelerations of scans 0 … n−1.
void smooth_axis(const Eigen::VectorXd& z, const AxisCvImmSpec& spec, Eigen::MatrixXd& truth,
                 Eigen::Index column) {
  const Eigen::Index n = z.size();
  const double T = spec.settings.sample_period;
  const double r = spec.settings.measurement_sigma * spec.settings.measurement_sigma;
  Eigen::Matrix2d F;
  F << 1.0, T, 0.0, 1.0;
  const Eigen::Vector2d G(0.5 * T * T, T);
  const Eigen::MatrixXd pi = spec.settings.transition(static_cast<int>(spec.process_noise.size()));
  ImmEstimator<2, 1> imm = build_axis_cv_imm(spec);
  GaussianState<2> start;
  start.mean << z(1), (z(1) - z(0)) / T;
  start.covariance << r, r / T, r / T, 2.0 * r / (T * T);
  imm.initialize(start);
  // Filtered moments from scan 1 on, and the process noise expected for the next transition.
  std::vector<Eigen::Vector2d> x(static_cast<std::size_t>(n));
  std::vector<Eigen::Matrix2d> P(static_cast<std::size_t>(n));
  std::vector<double> q_next(static_cast<std::size_t>(n), 0.0);
  for (Eigen::Index k = 1; k < n; ++k) {
    if (k >= 2 && imm.step(Vector<1>(z(k))) != StepStatus::kOk) {
      throw std::runtime_error("the smoother's IMM failed a step at scan " + std::to_string(k));
    }
    const auto i = static_cast<std::size_t>(k);
    x[i] = imm.estimate().mean;
    P[i] = imm.estimate().covariance;
    const Eigen::VectorXd c = pi.transpose() * imm.mode_probabilities();
    for (Eigen::Index j = 0; j < c.size(); ++j) {
      q_next[i] += c(j) * spec.process_noise[static_cast<std::size_t>(j)];
    }
  }
  // Rauch–Tung–Striebel backward over the moment-matched estimates.
  std::vector<Eigen::Vector2d> xs = x;
  for (Eigen::Index k = n - 2; k >= 1; --k) {
    const auto i = static_cast<std::size_t>(k);
    const Eigen::Vector2d predicted = F * x[i];
    const Eigen::Matrix2d predicted_covariance =
        F * P[i] * F.transpose() + q_next[i] * G * G.transpose();
    const Eigen::Matrix2d gain = P[i] * F.transpose() * predicted_covariance.inverse();
    xs[i] = x[i] + gain * (xs[i + 1] - predicted);
  }
  xs[0] = Eigen::Vector2d(z(0), xs[1](1));
  for (Eigen::Index k = 0; k < n; ++k) {
    const auto i = static_cast<std::size_t>(k);
    const auto next = static_cast<std::size_t>(k + 1 < n ? k + 1 : k);
    const auto from = static_cast<std::size_t>(k + 1 < n ? k : k - 1);
    truth(k, column) = xs[i](0);
    truth(k, column + 1) = xs[i](1);
    truth(k, column + 2) = (xs[next](1) - xs[from](1)) / T;
  }
}

}  // namespace

datasets::TrackSet smoothed_truth(const datasets::TrackSet& tracks, const AxisCvImmSpec& imm) {
  datasets::TrackSet smoothed = tracks;
  for (datasets::Track& track : smoothed.tracks) {
    if (!track.plots.allFinite()) {
      throw std::runtime_error("a window with a gap cannot be smoothed into labels");
    }
    if (track.plots.rows() < 3) throw std::runtime_error("a window needs 3 scans");
    track.truth.resize(track.plots.rows(), 6);
    smooth_axis(track.plots.col(0), imm, track.truth, 0);
    smooth_axis(track.plots.col(1), imm, track.truth, 3);
  }
  smoothed.has_truth = true;
  return smoothed;
}

}  // namespace imm::trainer::mlp
