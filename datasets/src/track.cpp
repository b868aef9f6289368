// SPDX-License-Identifier: Apache-2.0
#include "imm/datasets/track.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <numbers>
#include <string>

#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/random.hpp"
#include "imm/datasets/recorded.hpp"
#include "imm/datasets/sha256.hpp"
#include "imm/math/angle.hpp"
#include "imm/models/measurement/polar_measurement.hpp"
#include "imm/models/motion/constant_velocity.hpp"

namespace imm::datasets {
namespace {

// The stream a random track draws its program (start, segments) from; its noise uses the track
// seed itself.
constexpr std::uint64_t kProgramStream = 0x5052'4f47ULL;

/// A half-cosine lateral move: offset(t) = A/2 (1 − cos(π (t − t0)/τ)) along `lateral`.
struct LaneChange {
  double t0 = 0.0, duration = 1.0, offset = 0.0;
  Eigen::Vector2d lateral = Eigen::Vector2d::Zero();

  /// Position, velocity and acceleration of the offset at t (seed 002's cut-in shape).
  void add_at(double t, Eigen::Vector2d& p, Eigen::Vector2d& v, Eigen::Vector2d& a) const {
    if (t <= t0) return;
    if (t >= t0 + duration) {
      p += offset * lateral;
      return;
    }
    const double w = std::numbers::pi / duration;
    const double phase = w * (t - t0);
    const double half = 0.5 * offset;
    p += half * (1.0 - std::cos(phase)) * lateral;
    v += half * w * std::sin(phase) * lateral;
    a += half * w * w * std::cos(phase) * lateral;
  }
};

/// What a track does, before any noise: its start and, per transition k → k+1, the commanded
/// acceleration and turn rate; lane changes on top.
struct Program {
  Eigen::Vector2d position = Eigen::Vector2d::Zero(), velocity = Eigen::Vector2d::Zero();
  Eigen::MatrixXd acceleration;  ///< scans × 2
  Eigen::VectorXd turn_rate;     ///< scans
  std::vector<LaneChange> lanes;
};

Eigen::Vector2d left_of(const Eigen::Vector2d& velocity, Rng* rng) {
  const double speed = velocity.norm();
  if (speed > 0.0) return Eigen::Vector2d(-velocity.y(), velocity.x()) / speed;
  const double angle = rng != nullptr ? rng->uniform(0.0, 2.0 * std::numbers::pi) : 0.0;
  return {std::cos(angle), std::sin(angle)};
}

/// One transition of the truth: exact coordinated turn where ω ≠ 0, then the CV model with the
/// input u + w (the expressions of the CV simulation, so that a scripted regime reproduces it).
void advance(Vector<4>& x, const Vector<2>& input, double omega, double T,
             const LinearMotionModel<4>& motion, const Matrix<4, 2>& G) {
  if (omega != 0.0) {
    const double s = std::sin(omega * T), c = std::cos(omega * T);
    const double vx = x(1), vy = x(3);
    x(0) += (s * vx - (1.0 - c) * vy) / omega;
    x(2) += ((1.0 - c) * vx + s * vy) / omega;
    x(1) = c * vx - s * vy;
    x(3) = s * vx + c * vy;
    x += G * input;
  } else {
    x = motion.transition * x + G * input;
  }
}

void draw_start(const Start& start, const Regime& regime, Rng& rng, Program& program) {
  if (start.fixed) {
    program.position = start.position;
    program.velocity = start.velocity;
    return;
  }
  const double range = start.range.draw(rng);
  const double bearing = start.bearing.draw(rng);
  const Eigen::Vector2d origin =
      regime.sensor.kind == SensorKind::kPolar ? regime.sensor.position : Eigen::Vector2d::Zero();
  program.position = origin + range * Eigen::Vector2d(std::sin(bearing), std::cos(bearing));
  const double heading = start.inbound ? bearing + std::numbers::pi + start.heading.draw(rng)
                                       : start.heading.draw(rng);
  const double speed = start.speed.draw(rng);
  program.velocity = speed * Eigen::Vector2d(std::sin(heading), std::cos(heading));
}

int transitions_of(double seconds, double T) {
  return std::max(1, static_cast<int>(std::lround(seconds / T)));
}

int first_transition(double seconds, double T) {
  return static_cast<int>(std::ceil(seconds / T - 1e-9));
}

// Zigzag of seed 003: per period +a for a quarter, −a for two, +a for one, the sign alternating
// from period to period, so each period ends with the lateral offset and velocity back at zero.
void add_zigzag(Program& program, int first, int quarter, const std::vector<double>& amplitudes,
                const Eigen::Vector2d& lateral) {
  const auto n = static_cast<int>(program.acceleration.rows());
  int k = first;
  for (std::size_t i = 0; i < amplitudes.size(); ++i) {
    const double sign = i % 2 == 0 ? 1.0 : -1.0;
    const Eigen::Vector2d a = sign * amplitudes[i] * lateral;
    for (int j = 0; j < 4 * quarter; ++j, ++k) {
      if (k >= n) return;
      program.acceleration.row(k) +=
          (j < quarter || j >= 3 * quarter ? a : Eigen::Vector2d(-a)).transpose();
    }
  }
}

Program scripted_program(const Regime& regime, const ScriptedCase& script, Rng& rng) {
  const double T = regime.sample_period;
  Program program;
  draw_start(script.start ? *script.start : regime.start, regime, rng, program);
  program.acceleration = Eigen::MatrixXd::Zero(regime.scans, 2);
  program.turn_rate = Eigen::VectorXd::Zero(regime.scans);
  const Eigen::Vector2d lateral = left_of(program.velocity, nullptr);
  for (const ScriptedSegment& s : script.segments) {
    const int first = first_transition(s.start, T);
    const int end = std::min(regime.scans, first_transition(s.end, T));
    switch (s.kind) {
      case SegmentKind::kConstantAcceleration:
        for (int k = first; k < end; ++k) program.acceleration.row(k) += s.acceleration.transpose();
        break;
      case SegmentKind::kTurn:
        for (int k = first; k < end; ++k) program.turn_rate(k) += s.rate;
        break;
      case SegmentKind::kZigzag:
        add_zigzag(program, first, transitions_of(s.quarter, T), s.amplitudes, lateral);
        break;
      case SegmentKind::kLaneChange:
        program.lanes.push_back({s.start, s.end - s.start, s.offset, lateral});
        break;
      case SegmentKind::kConstantVelocity:
        break;
    }
  }
  return program;
}

const MenuEntry& pick(const std::vector<MenuEntry>& menu, Rng& rng) {
  const double u = rng.uniform();
  double cumulative = 0.0;
  for (const MenuEntry& e : menu) {
    cumulative += e.probability;
    if (u < cumulative) return e;
  }
  return menu.back();
}

Program random_program(const Regime& regime, Rng& rng) {
  const double T = regime.sample_period;
  const int n = regime.scans;
  Program program;
  draw_start(regime.start, regime, rng, program);
  program.acceleration = Eigen::MatrixXd::Zero(n, 2);
  program.turn_rate = Eigen::VectorXd::Zero(n);
  const auto motion = constant_velocity<2>(T, 0.0);
  const Matrix<4, 2> G = cv_input_gain<2>(T);
  // The noise-free state at the start of the next segment: where relative directions are taken.
  Vector<4> nominal(program.position(0), program.velocity(0), program.position(1),
                    program.velocity(1));
  int k = 0;
  while (k < n - 1) {
    const MenuEntry& e = pick(regime.menu, rng);
    const Eigen::Vector2d velocity(nominal(1), nominal(3));
    int length = e.kind == SegmentKind::kZigzag ? 0 : transitions_of(e.duration.draw(rng), T);
    switch (e.kind) {
      case SegmentKind::kConstantAcceleration: {
        const double magnitude = e.magnitude.draw(rng);
        const double sign = rng.uniform() < 0.5 ? -1.0 : 1.0;
        Eigen::Vector2d direction;
        switch (e.direction) {
          case Direction::kAlong:
            direction = velocity.norm() > 0.0 ? Eigen::Vector2d(velocity.normalized())
                                              : left_of(velocity, &rng);
            break;
          case Direction::kLateral:
            direction = left_of(velocity, &rng);
            break;
          case Direction::kAny: {
            const double angle = rng.uniform(0.0, 2.0 * std::numbers::pi);
            direction = Eigen::Vector2d(std::cos(angle), std::sin(angle));
            break;
          }
          case Direction::kAxis:
            direction = rng.uniform() < 0.5 ? Eigen::Vector2d::UnitX() : Eigen::Vector2d::UnitY();
            break;
        }
        for (int j = k; j < std::min(n, k + length); ++j) {
          program.acceleration.row(j) = (sign * magnitude * direction).transpose();
        }
        break;
      }
      case SegmentKind::kTurn: {
        const double rate = e.rate.draw(rng) * (rng.uniform() < 0.5 ? -1.0 : 1.0);
        for (int j = k; j < std::min(n, k + length); ++j) program.turn_rate(j) = rate;
        break;
      }
      case SegmentKind::kZigzag: {
        const int quarter = transitions_of(e.quarter.draw(rng), T);
        const int periods =
            e.min_periods + static_cast<int>(rng.below(
                                static_cast<std::uint64_t>(e.max_periods - e.min_periods) + 1));
        std::vector<double> amplitudes(static_cast<std::size_t>(periods));
        for (double& a : amplitudes) a = e.magnitude.draw(rng);
        const Eigen::Vector2d lateral =
            (rng.uniform() < 0.5 ? -1.0 : 1.0) * left_of(velocity, &rng);
        add_zigzag(program, k, quarter, amplitudes, lateral);
        length = 4 * quarter * periods;
        break;
      }
      case SegmentKind::kLaneChange: {
        const double offset = e.magnitude.draw(rng) * (rng.uniform() < 0.5 ? -1.0 : 1.0);
        program.lanes.push_back({k * T, length * T, offset, left_of(velocity, &rng)});
        break;
      }
      case SegmentKind::kConstantVelocity:
        break;
    }
    for (int j = k; j < std::min(n, k + length); ++j) {
      advance(nominal, program.acceleration.row(j).transpose(), program.turn_rate(j), T, motion, G);
    }
    k += length;
  }
  return program;
}

}  // namespace

Track draw_track(const Regime& regime, Split split, int index, std::uint64_t seed) {
  if (regime.recorded) return recorded_track(regime, split, index);
  const double T = regime.sample_period;
  const int n = regime.scans;
  Track track;
  track.seed = track_seed(regime, split, index, seed);
  track.case_index = regime.scripted() ? index % regime.case_count() : 0;
  track.noise = regime.noise_of(track.case_index);
  Rng program_rng(derive_seed(track.seed, kProgramStream));
  const Program program =
      regime.scripted()
          ? scripted_program(regime, regime.cases[static_cast<std::size_t>(track.case_index)],
                             program_rng)
          : random_program(regime, program_rng);

  const auto motion = constant_velocity<2>(T, 0.0);
  const Matrix<4, 2> G = cv_input_gain<2>(T);
  const Eigen::Matrix2d R = track.noise.covariance();
  const Eigen::Matrix2d L = Eigen::LLT<Eigen::Matrix2d>(R).matrixL();
  const bool correlated = track.noise.correlation != 0.0;
  const PolarMeasurement<4> polar(0, 2, R);
  const Sensor& sensor = regime.sensor;

  Rng rng(track.seed);
  track.truth.resize(n, 6);
  track.plots.resize(n, 2);
  track.maneuvering.assign(static_cast<std::size_t>(n), false);
  Vector<4> x(program.position(0), program.velocity(0), program.position(1), program.velocity(1));
  for (int k = 0; k < n; ++k) {
    const double t = k * T;
    Eigen::Vector2d p(x(0), x(2)), v(x(1), x(3));
    Eigen::Vector2d a = program.acceleration.row(k).transpose();
    const double omega = program.turn_rate(k);
    a += omega * Eigen::Vector2d(-v.y(), v.x());  // the turn's centripetal acceleration
    bool maneuvering = omega != 0.0 || program.acceleration.row(k).squaredNorm() > 0.0;
    for (const LaneChange& lane : program.lanes) {
      lane.add_at(t, p, v, a);
      maneuvering = maneuvering || (t >= lane.t0 && t < lane.t0 + lane.duration);
    }
    track.truth.row(k) << p(0), v(0), a(0), p(1), v(1), a(1);
    track.maneuvering[static_cast<std::size_t>(k)] = maneuvering;
    switch (sensor.kind) {
      case SensorKind::kCartesian:
        if (correlated) {
          const Eigen::Vector2d e(rng.normal(), rng.normal());
          track.plots.row(k) = (p + L * e).transpose();
        } else {
          track.plots(k, 0) = p(0) + track.noise.sigma(0) * rng.normal();
          track.plots(k, 1) = p(1) + track.noise.sigma(1) * rng.normal();
        }
        break;
      case SensorKind::kPolar: {
        const Eigen::Vector2d relative = p - sensor.position;
        const Vector<2> clean = polar.predict(Vector<4>(relative(0), v(0), relative(1), v(1)));
        track.plots(k, 0) = clean(0) + track.noise.sigma(0) * rng.normal();
        track.plots(k, 1) = wrap_angle(clean(1) + track.noise.sigma(1) * rng.normal());
        break;
      }
      case SensorKind::kRangeSensor: {
        const Eigen::Vector2d clean = sensor.response(p);
        const Eigen::Vector2d e(rng.normal(), rng.normal());
        track.plots.row(k) = (clean + L * e).transpose();
        break;
      }
    }
    const Vector<2> w(regime.process_noise_sigma * rng.normal(),
                      regime.process_noise_sigma * rng.normal());
    const Vector<2> u = program.acceleration.row(k).transpose();
    advance(x, u + w, omega, T, motion, G);
  }
  return track;
}

TrackSet draw_split(const Regime& regime, Split split, std::uint64_t seed, int count) {
  // A count the caller names (imm-data --count, imm-eval --runs, Regime.draw's runs) is held to
  // what a split may hold, not left to run out of memory.
  require(count <= kMaxSplitTracks, "count",
          "at most 10⁶ tracks are drawn at once, got " + std::to_string(count));
  if (regime.recorded) return recorded_split(regime, split, count);
  TrackSet set;
  set.regime = regime.name;
  set.split = split;
  set.seed = split == Split::kTest ? seed : regime.splits.seed;
  set.sample_period = regime.sample_period;
  set.scans = regime.scans;
  const int n = count >= 0 ? count : split_size(regime, split);
  set.tracks.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) set.tracks.push_back(draw_track(regime, split, i, seed));
  return set;
}

RangeSensorData draw_calibration(const Sensor& sensor, std::uint64_t seed) {
  const SensorCalibration& c = sensor.calibration;
  Rng rng(derive_seed(seed, 2));
  RangeSensorData data;
  data.positions.resize(c.samples, 2);
  data.outputs.resize(c.samples, 2);
  for (int q = 0; q < c.samples; ++q) {
    const Eigen::Vector2d p(rng.uniform(c.lower(0), c.upper(0)),
                            rng.uniform(c.lower(1), c.upper(1)));
    data.positions.row(q) = p.transpose();
    const Eigen::Vector2d m = sensor.response(p);
    data.outputs.row(q) << m(0) + rng.normal(0.0, c.noise_sigma),
        m(1) + rng.normal(0.0, c.noise_sigma);
  }
  return data;
}

std::string TrackSet::digest() const {
  Sha256 hash;
  for (const Track& track : tracks) {
    hash_matrix(hash, track.truth);
    hash_matrix(hash, track.plots);
  }
  if (recorded) {  // which windows share a recording decides the splits
    for (const int r : recording) hash.update(&r, sizeof r);
    for (const std::string& name : recording_names) hash.update(name + '\n');
  }
  return hash.hex_digest();
}

}  // namespace imm::datasets
