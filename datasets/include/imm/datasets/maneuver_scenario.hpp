#pragma once
/// Planar target trajectories with piecewise-constant acceleration (maneuver segments), simulated
/// with the runtime's own CV model — x(k+1) = F x(k) + G (u(k) + w(k)) (seed 000 eq. 1) with the
/// noise switched on — and measured in Cartesian or polar coordinates with the runtime's
/// measurement models. The seed-000 scenario is one instance (seed000_scenario()).
///
/// Time convention: the truth is given at scans k = 0 … steps − 1 (t = kT) and every scan is
/// measured. A segment [start, end) applies its acceleration to the transitions k → k + 1 for
/// start ≤ k < end, so "scans 40–60" of seed 000 is 20 periods of acceleration.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "imm/filters/plain_imm.hpp"

namespace imm::datasets {

struct ManeuverSegment {
  int start = 0;  ///< first scan whose transition is accelerated
  int end = 0;    ///< one past the last
  Eigen::Vector2d acceleration = Eigen::Vector2d::Zero();
};

/// A coordinated turn: the velocity rotates at a constant rate ω (rad/s, positive
/// counter-clockwise) over the transitions start ≤ k < end, speed unchanged (exact kinematics).
struct TurnSegment {
  int start = 0;
  int end = 0;
  double omega = 0.0;
};

struct MeasurementNoise {
  MeasurementKind kind = MeasurementKind::kCartesian;
  Eigen::Vector2d sigma = Eigen::Vector2d::Ones();  ///< cartesian [σx, σy]; polar [σr, σθ (rad)]

  [[nodiscard]] Eigen::Matrix2d covariance() const { return sigma.cwiseAbs2().asDiagonal(); }
};

struct ManeuverScenario {
  std::string name = "maneuver";
  double sample_period = 1.0;  ///< T, s
  int steps = 100;             ///< scans per run
  int runs = 1;                ///< Monte Carlo runs
  std::uint64_t seed = 1;      ///< run r uses derive_seed(seed, r)
  Eigen::Vector2d initial_position = Eigen::Vector2d::Zero();
  Eigen::Vector2d initial_velocity = Eigen::Vector2d::Zero();
  double process_noise_sigma = 0.0;  ///< σ_w of the white acceleration per axis
  MeasurementNoise measurement;
  std::vector<ManeuverSegment> maneuvers;
  std::vector<TurnSegment> turns;

  /// Throws InvalidParameter naming the offending field.
  void validate() const;
  /// The deterministic acceleration input u(k), steps × 2.
  [[nodiscard]] Eigen::MatrixXd acceleration_input() const;
};

/// The seed-000 experiment (SPEC §7): T = 1 s, σ_z = 0.5 km, σ_w = 0.001 km/s², start 22.4 km out
/// on the 45° line moving along it at 0.015 km/s (heading ours: the seed gives the speed only),
/// accelerations x 0.01 km/s² at scans 40–60, y 0.06 at 80–90, x −0.03 at 120–140, 160 scans,
/// 100 runs. Units km and s.
[[nodiscard]] ManeuverScenario seed000_scenario();

/// A zigzag of lateral accelerations along the unit vector `lateral`: period i applies
/// s_i a_i for `quarter` transitions, −s_i a_i for 2·quarter and s_i a_i for `quarter` again
/// (s_i = +1, −1, +1, … alternating, a_i = magnitudes[i]), so that after every period the lateral
/// velocity and offset are back to zero and the path has swung a_i quarter² to one side, then to
/// the other. The segments start at transition `start`.
[[nodiscard]] std::vector<ManeuverSegment> zigzag_maneuvers(int start, int quarter,
                                                            const std::vector<double>& magnitudes,
                                                            const Eigen::Vector2d& lateral);

/// Seed 003's experiment (SPEC §7), in metres and seconds: from 300 km east / 200 km north toward
/// the observer at 450 m/s, T = 1 s, 400 scans, σ_z = 100 m per axis, process noise σ_w =
/// 0.5 m/s² (ours: the seed says only "simple process noise"); straight for the first third, a
/// zigzag perpendicular to the path over transitions 136–263 (four periods of 32 s, |a| = 30, 40,
/// 50, 60 m/s² — the seed's 0.3–0.6 km/s² scaled by 1/10, SPEC §7), straight again; 100 runs.
/// `acceleration_scale` multiplies the accelerations (10: the seed's literal values).
[[nodiscard]] ManeuverScenario seed003_scenario(double acceleration_scale = 1.0);

/// The scans of seed 003's manoeuvre segment, [first, last): the transitions 136–263 show in the
/// states of scans 137–264.
inline constexpr int kSeed003ManeuverFirstScan = 137;
inline constexpr int kSeed003ManeuverEndScan = 265;

/// Seed 004's scenarios (SPEC §7): from 140 km at azimuth 45° with V = (−100, −100) m/s, T = 2 s,
/// 250 scans, polar plots σ_R = 50 m, σ_θ = 0.5°, 100 runs, no process noise (units m, s, rad).
/// Scenario 2 adds coordinated turns of ω = 3.82°/s over 200–223 s and 276–300 s (Table 1).
[[nodiscard]] ManeuverScenario seed004_scenario(int number);

/// One simulated Monte Carlo set.
struct ScenarioData {
  Eigen::VectorXd time;                       ///< steps
  Eigen::MatrixXd acceleration_input;         ///< steps × 2, u(k)
  std::vector<Eigen::MatrixXd> truth;         ///< per run, steps × 4: x, vx, y, vy
  std::vector<Eigen::MatrixXd> measurements;  ///< per run, steps × 2: zx, zy or range, azimuth

  /// Appends the first run of `other` (a set of differently drawn scenarios of equal length);
  /// time and acceleration_input are taken from the first run appended.
  void append_first_run(const ScenarioData& other) {
    if (truth.empty()) {
      time = other.time;
      acceleration_input = other.acceleration_input;
    }
    truth.push_back(other.truth.front());
    measurements.push_back(other.measurements.front());
  }
};

/// Simulates every run; run r depends only on (scenario, r).
[[nodiscard]] ScenarioData simulate(const ManeuverScenario& scenario);

/// SHA-256 over the shapes and little-endian bytes of time, truth and measurements.
[[nodiscard]] std::string digest(const ScenarioData& data);

}  // namespace imm::datasets
