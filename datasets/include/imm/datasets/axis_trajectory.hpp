// SPDX-License-Identifier: Apache-2.0
#pragma once
/// One-axis trajectories (per-axis filters: seed 000's tables, seed 001's input estimator),
/// simulated with the runtime's CV model, x(k+1) = F x(k) + G (u(k) + w(k)), z(k) = p(k) + v(k).

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "imm/estimation/gaussian_state.hpp"

namespace imm::datasets {

struct AxisTrajectory {
  Eigen::VectorXd position, velocity, acceleration_input, measurement;
};

struct AxisNoise {
  double sample_period = 1.0;
  double process_noise_sigma = 0.0;  ///< σ of the white acceleration w
  double measurement_sigma = 1.0;    ///< σ of v
};

class Rng;

/// Truth from (p₀, v₀) under the input u (one entry per scan); per scan the measurement noise is
/// drawn from `rng`, then the process noise.
[[nodiscard]] AxisTrajectory simulate_axis(double initial_position, double initial_velocity,
                                           const Eigen::VectorXd& acceleration_input,
                                           const AxisNoise& noise, Rng& rng);

/// The same with a fresh stream seeded by `seed`.
[[nodiscard]] AxisTrajectory simulate_axis(double initial_position, double initial_velocity,
                                           const Eigen::VectorXd& acceleration_input,
                                           const AxisNoise& noise, std::uint64_t seed);

struct TrackSet;

/// The one-axis trajectories of a set of 2-D tracks: x, then y, of every track in order (the
/// per-axis filters' view of a regime; acceleration_input is the truth's commanded acceleration).
[[nodiscard]] std::vector<AxisTrajectory> axis_trajectories(const TrackSet& set);

/// The two-point start of a one-axis filter at scan 1: position z(1), velocity (z(1) − z(0)) / T,
/// and their covariance for plots of variance R — [[R, R/T], [R/T, 2R/T²]].
[[nodiscard]] GaussianState<2> two_point_start(const AxisTrajectory& trajectory,
                                               double sample_period, double measurement_variance);

}  // namespace imm::datasets
