// SPDX-License-Identifier: Apache-2.0
#include "imm/datasets/axis_trajectory.hpp"

#include "imm/datasets/random.hpp"
#include "imm/datasets/track.hpp"
#include "imm/models/motion/constant_velocity.hpp"

namespace imm::datasets {

AxisTrajectory simulate_axis(double initial_position, double initial_velocity,
                             const Eigen::VectorXd& acceleration_input, const AxisNoise& noise,
                             std::uint64_t seed) {
  Rng rng(seed);
  return simulate_axis(initial_position, initial_velocity, acceleration_input, noise, rng);
}

AxisTrajectory simulate_axis(double initial_position, double initial_velocity,
                             const Eigen::VectorXd& acceleration_input, const AxisNoise& noise,
                             Rng& rng) {
  const double T = noise.sample_period;
  const auto motion = constant_velocity<1>(T, 0.0);
  const Vector<2> G = cv_axis_input_gain(T);
  const Eigen::Index n = acceleration_input.size();
  AxisTrajectory t;
  t.position.resize(n);
  t.velocity.resize(n);
  t.measurement.resize(n);
  t.acceleration_input = acceleration_input;
  Vector<2> x(initial_position, initial_velocity);
  for (Eigen::Index k = 0; k < n; ++k) {
    t.position(k) = x(0);
    t.velocity(k) = x(1);
    t.measurement(k) = x(0) + noise.measurement_sigma * rng.normal();
    const double w = noise.process_noise_sigma * rng.normal();
    x = motion.transition * x + G * (acceleration_input(k) + w);
  }
  return t;
}

std::vector<AxisTrajectory> axis_trajectories(const TrackSet& set) {
  std::vector<AxisTrajectory> result;
  result.reserve(2 * set.tracks.size());
  for (const Track& track : set.tracks) {
    for (Eigen::Index axis = 0; axis < 2; ++axis) {
      AxisTrajectory t;
      t.position = track.truth.col(3 * axis);
      t.velocity = track.truth.col(3 * axis + 1);
      t.acceleration_input = track.truth.col(3 * axis + 2);
      t.measurement = track.plots.col(axis);
      result.push_back(std::move(t));
    }
  }
  return result;
}

GaussianState<2> two_point_start(const AxisTrajectory& trajectory, double sample_period,
                                 double measurement_variance) {
  const double T = sample_period, R = measurement_variance;
  const Eigen::VectorXd& z = trajectory.measurement;
  GaussianState<2> start;
  start.mean << z(1), (z(1) - z(0)) / T;
  start.covariance << R, R / T, R / T, 2.0 * R / (T * T);
  return start;
}

}  // namespace imm::datasets
