#include "imm/datasets/maneuver_scenario.hpp"

#include <bit>
#include <cmath>
#include <numbers>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/datasets/random.hpp"
#include "imm/datasets/sha256.hpp"
#include "imm/math/angle.hpp"
#include "imm/models/constant_velocity.hpp"
#include "imm/models/polar_measurement.hpp"

namespace imm::datasets {
void ManeuverScenario::validate() const {
  require(!name.empty(), "name", "must not be empty");
  limits::require_in(sample_period, limits::kSamplePeriod, "sample_period");
  require(steps >= 2 && steps <= 10'000'000, "steps", "must be in [2, 10⁷]");
  require(runs >= 1 && runs <= 1'000'000, "runs", "must be in [1, 10⁶]");
  for (Eigen::Index i = 0; i < 2; ++i) {
    limits::require_magnitude(initial_position(i), limits::kDistance, "initial_position");
    limits::require_magnitude(initial_velocity(i), limits::kSpeed, "initial_velocity");
    limits::require_in(measurement.sigma(i), limits::kSigma, "measurement.sigma");
  }
  limits::require_in(process_noise_sigma, limits::kAcceleration, "process_noise_sigma");
  for (std::size_t i = 0; i < turns.size(); ++i) {
    const TurnSegment& t = turns[i];
    const std::string field = "turns[" + std::to_string(i) + "]";
    require(t.start >= 0, field + ".start", "must be ≥ 0");
    require(t.start < t.end && t.end <= steps, field + ".end",
            "segment [start, end) must satisfy 0 ≤ start < end ≤ steps");
    limits::require_magnitude(t.omega, limits::kTurnRate, field + ".omega");
  }
  for (std::size_t i = 0; i < maneuvers.size(); ++i) {
    const ManeuverSegment& m = maneuvers[i];
    const std::string field = "maneuvers[" + std::to_string(i) + "]";
    require(m.start >= 0, field + ".start", "must be ≥ 0");
    require(m.start < m.end && m.end <= steps, field + ".end",
            "segment [start, end) must satisfy 0 ≤ start < end ≤ steps");
    for (Eigen::Index a = 0; a < 2; ++a) {
      limits::require_magnitude(m.acceleration(a), limits::kAcceleration, field + ".acceleration");
    }
  }
}

Eigen::MatrixXd ManeuverScenario::acceleration_input() const {
  Eigen::MatrixXd u = Eigen::MatrixXd::Zero(steps, 2);
  for (const ManeuverSegment& m : maneuvers) {
    for (int k = m.start; k < m.end; ++k) u.row(k) += m.acceleration.transpose();
  }
  return u;
}

ManeuverScenario seed000_scenario() {
  ManeuverScenario s;
  s.name = "seed000";
  s.sample_period = 1.0;
  s.steps = 160;
  s.runs = 100;
  s.seed = 1;
  const double c = std::cos(std::numbers::pi / 4.0);
  s.initial_position = 22.4 * Eigen::Vector2d(c, c);
  s.initial_velocity = 0.015 * Eigen::Vector2d(c, c);
  s.process_noise_sigma = 0.001;
  s.measurement.kind = MeasurementKind::kCartesian;
  s.measurement.sigma = Eigen::Vector2d(0.5, 0.5);
  s.maneuvers = {{40, 60, Eigen::Vector2d(0.01, 0.0)},
                 {80, 90, Eigen::Vector2d(0.0, 0.06)},
                 {120, 140, Eigen::Vector2d(-0.03, 0.0)}};
  return s;
}

std::vector<ManeuverSegment> zigzag_maneuvers(int start, int quarter,
                                              const std::vector<double>& magnitudes,
                                              const Eigen::Vector2d& lateral) {
  if (quarter < 1) throw InvalidParameter("quarter", "must be at least one transition");
  std::vector<ManeuverSegment> segments;
  int k = start;
  for (std::size_t i = 0; i < magnitudes.size(); ++i) {
    const double sign = i % 2 == 0 ? 1.0 : -1.0;
    const Eigen::Vector2d a = sign * magnitudes[i] * lateral;
    segments.push_back({k, k + quarter, a});
    segments.push_back({k + quarter, k + 3 * quarter, -a});
    segments.push_back({k + 3 * quarter, k + 4 * quarter, a});
    k += 4 * quarter;
  }
  return segments;
}

ManeuverScenario seed003_scenario(double acceleration_scale) {
  if (!(acceleration_scale > 0.0) || !std::isfinite(acceleration_scale)) {
    throw InvalidParameter("acceleration_scale", "must be positive and finite");
  }
  ManeuverScenario s;
  s.name = "seed003";
  s.sample_period = 1.0;
  s.steps = 400;
  s.runs = 100;
  s.seed = 1;
  s.initial_position = Eigen::Vector2d(300e3, 200e3);
  const Eigen::Vector2d heading = -s.initial_position.normalized();
  s.initial_velocity = 450.0 * heading;
  s.process_noise_sigma = 0.5;
  s.measurement.kind = MeasurementKind::kCartesian;
  s.measurement.sigma = Eigen::Vector2d(100.0, 100.0);
  const Eigen::Vector2d lateral(-heading.y(), heading.x());
  std::vector<double> magnitudes = {30.0, 40.0, 50.0, 60.0};
  for (double& a : magnitudes) a *= acceleration_scale;
  s.maneuvers = zigzag_maneuvers(136, 8, magnitudes, lateral);
  return s;
}

ManeuverScenario seed004_scenario(int number) {
  if (number != 1 && number != 2)
    throw InvalidParameter("scenario", "seed 004 has scenarios 1 and 2");
  ManeuverScenario s;
  s.name = number == 1 ? "seed004-1" : "seed004-2";
  s.sample_period = 2.0;
  s.steps = 250;
  s.runs = 100;
  s.seed = 1;
  const double c = std::cos(std::numbers::pi / 4.0);
  s.initial_position = 140e3 * Eigen::Vector2d(c, c);
  s.initial_velocity = Eigen::Vector2d(-100.0, -100.0);
  s.process_noise_sigma = 0.0;
  s.measurement.kind = MeasurementKind::kPolar;
  s.measurement.sigma = Eigen::Vector2d(50.0, 0.5 * std::numbers::pi / 180.0);
  if (number == 2) {
    const double omega = 3.82 * std::numbers::pi / 180.0;
    // 200–223 s and 276–300 s at T = 2 s: transitions 100–111 and 138–149.
    s.turns = {{100, 112, omega}, {138, 150, omega}};
  }
  return s;
}

ScenarioData simulate(const ManeuverScenario& scenario) {
  scenario.validate();
  const double T = scenario.sample_period;
  const auto motion = constant_velocity<2>(T, 0.0);
  const Matrix<4, 2> G = cv_input_gain<2>(T);
  const Eigen::Matrix2d R = scenario.measurement.covariance();
  const PolarMeasurement<4> polar(0, 2, R);

  ScenarioData data;
  data.time = Eigen::VectorXd::LinSpaced(scenario.steps, 0.0, T * (scenario.steps - 1));
  data.acceleration_input = scenario.acceleration_input();
  data.truth.reserve(static_cast<std::size_t>(scenario.runs));
  data.measurements.reserve(static_cast<std::size_t>(scenario.runs));
  for (int run = 0; run < scenario.runs; ++run) {
    Rng rng(derive_seed(scenario.seed, static_cast<std::uint64_t>(run)));
    Eigen::MatrixXd truth(scenario.steps, 4);
    Eigen::MatrixXd z(scenario.steps, 2);
    Vector<4> x(scenario.initial_position(0), scenario.initial_velocity(0),
                scenario.initial_position(1), scenario.initial_velocity(1));
    for (int k = 0; k < scenario.steps; ++k) {
      truth.row(k) = x.transpose();
      if (scenario.measurement.kind == MeasurementKind::kCartesian) {
        z(k, 0) = x(0) + scenario.measurement.sigma(0) * rng.normal();
        z(k, 1) = x(2) + scenario.measurement.sigma(1) * rng.normal();
      } else {
        const Vector<2> clean = polar.predict(x);
        z(k, 0) = clean(0) + scenario.measurement.sigma(0) * rng.normal();
        z(k, 1) = wrap_angle(clean(1) + scenario.measurement.sigma(1) * rng.normal());
      }
      const Vector<2> w(scenario.process_noise_sigma * rng.normal(),
                        scenario.process_noise_sigma * rng.normal());
      const Vector<2> u = data.acceleration_input.row(k).transpose();
      double omega = 0.0;
      for (const TurnSegment& turn : scenario.turns) {
        if (k >= turn.start && k < turn.end) omega += turn.omega;
      }
      if (omega != 0.0) {
        // Exact coordinated turn: the velocity rotates by ωT, the position follows the arc.
        const double s = std::sin(omega * T), c = std::cos(omega * T);
        const double vx = x(1), vy = x(3);
        x(0) += (s * vx - (1.0 - c) * vy) / omega;
        x(2) += ((1.0 - c) * vx + s * vy) / omega;
        x(1) = c * vx - s * vy;
        x(3) = s * vx + c * vy;
        x += G * (u + w);
      } else {
        x = motion.transition * x + G * (u + w);
      }
    }
    data.truth.push_back(std::move(truth));
    data.measurements.push_back(std::move(z));
  }
  return data;
}

std::string digest(const ScenarioData& data) {
  Sha256 hash;
  hash_matrix(hash, data.time);
  hash_matrix(hash, data.acceleration_input);
  for (const auto& truth : data.truth) hash_matrix(hash, truth);
  for (const auto& z : data.measurements) hash_matrix(hash, z);
  return hash.hex_digest();
}

}  // namespace imm::datasets
