#pragma once
/// Seed 002's data (SPEC §7): a distorted long-range sensor, the 8000-sample data set its TSK model
/// is fitted on, and the vehicle cut-in scenario of §4. Units m, s.
///
/// Distortion (ours; the seed shows only its data, Fig. 3): the range compresses beyond a knee,
///   η_m = η                               for η ≤ knee,
///   η_m = knee + L tanh((η − knee) / L)   beyond,
/// and the lateral coordinate is scaled by the same ratio, ξ_m = ξ η_m / η; plus white noise.
/// The default knee is 40 m and L = 30 m (the "hard" sensor: L = 10 m, where the range is nearly
/// unobservable beyond ~60 m: dη_m/dη = sech²(2) ≈ 0.07 at 60 m).

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace imm::datasets {

struct RangeDistortion {
  double knee = 40.0;      ///< m
  double softness = 30.0;  ///< L, m
  /// Throws InvalidParameter naming the field.
  void validate() const;
  /// The noise-free sensor output (ξ_m, η_m) of a position (ξ, η).
  [[nodiscard]] Eigen::Vector2d apply(const Eigen::Vector2d& position) const;
};

struct RangeSensorDataConfig {
  RangeDistortion distortion;
  int samples = 8000;
  Eigen::Vector2d lower = Eigen::Vector2d(-6.0, 1.0);  ///< ξ, η box of the obstacles, m
  Eigen::Vector2d upper = Eigen::Vector2d(6.0, 100.0);
  double noise_sigma = 0.05;  ///< sensor noise per output while collecting the data, m
  std::uint64_t seed = 1;
  void validate() const;
};

struct RangeSensorData {
  Eigen::MatrixXd positions;  ///< samples × 2: true (ξ, η)
  Eigen::MatrixXd outputs;    ///< samples × 2: measured (z₁, z₂)
};

/// Obstacles uniform in the box, measured through the distortion with noise. Seeded.
[[nodiscard]] RangeSensorData simulate_range_sensor(const RangeSensorDataConfig& config);

/// The cut-in of seed 002 §4: the host drives at 30 m/s in lane 2, the target at 33 m/s starts
/// beside it in lane 1 (ξ = lane_offset, η = initial_gap), cuts in front of the host over
/// cut_in_start … cut_in_end and returns to lane 1 over return_start … return_end; lateral moves
/// follow a half-cosine (continuous position and velocity; the acceleration
/// jumps by ±(π/τ)² · lane_offset / 2 at each move's ends). Relative coordinates in the
/// host frame, state [ξ, ξ̇, ξ̈, η, η̇, η̈]; plots are the distorted sensor output plus N(0, R).
struct CutInScenario {
  double sample_period = 0.1;                     ///< T, s
  int steps = 200;                                ///< 20 s
  double host_speed = 30.0, target_speed = 33.0;  ///< m/s
  double lane_offset = 3.5;                       ///< m
  double initial_gap = 0.0;                       ///< η at t = 0, m (the seed: "same position")
  double cut_in_start = 1.0, cut_in_end = 4.0;    ///< s
  double return_start = 14.0, return_end = 18.0;  ///< s
  RangeDistortion distortion;
  Eigen::Matrix2d measurement_covariance = Eigen::Matrix2d::Identity();  ///< R
  int runs = 100;
  std::uint64_t seed = 1;
  void validate() const;
};

struct CutInData {
  Eigen::MatrixXd truth;                      ///< steps × 6
  std::vector<Eigen::MatrixXd> measurements;  ///< per run, steps × 2
};

[[nodiscard]] CutInData simulate_cut_in(const CutInScenario& scenario);

}  // namespace imm::datasets
