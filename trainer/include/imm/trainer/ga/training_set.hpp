#pragma once
/// Training data for the fuzzy rule tables: one-axis trajectories (the fuzzy-noise KF is a
/// per-axis filter), simulated with the runtime's CV model x(k+1) = F x + G (u(k) + w(k)) and
/// measured z = p + v, as seed 000 eq. (1)–(2).
///
/// Profiles of the acceleration input u(k) for a maneuver level u:
/// - kManeuver (the seed's literal reading, "for an acceleration input u"): ±u throughout;
/// - kMixed: constant-velocity and ±u maneuver segments alternate, segment lengths uniform in a
///   configured range, so that a table sees both what it must ignore and what it must follow.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "imm/datasets/axis_trajectory.hpp"

namespace imm::trainer::ga {

enum class TrainingProfile { kManeuver, kMixed };

[[nodiscard]] std::string_view to_string(TrainingProfile profile);

struct TrainingSetOptions {
  double sample_period = 1.0;
  double measurement_sigma = 0.5;
  double process_noise_sigma = 0.001;
  double maneuver_level = 0.01;
  TrainingProfile profile = TrainingProfile::kMixed;
  int trajectories = 12;
  int steps = 160;
  int min_segment = 10;  ///< scans, mixed profile
  int max_segment = 40;
  double initial_speed = 0.015;
  std::uint64_t seed = 1;
};

using datasets::AxisTrajectory;

struct TrainingSet {
  std::vector<AxisTrajectory> trajectories;
  double sample_period = 1.0;
  double measurement_variance = 0.25;
  /// SHA-256 of the measurements and truth (for the model's dataset_digest).
  [[nodiscard]] std::string digest() const;
  [[nodiscard]] long total_steps() const;
};

/// Simulates a training set; trajectory t depends only on (seed, t).
[[nodiscard]] TrainingSet make_training_set(const TrainingSetOptions& options);

}  // namespace imm::trainer::ga
