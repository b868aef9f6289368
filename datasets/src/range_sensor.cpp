#include "imm/datasets/range_sensor.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>
#include <numbers>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/datasets/random.hpp"

namespace imm::datasets {
namespace {

// Half-cosine move from a to b over [t0, t1]: position, velocity, acceleration at t.
Eigen::Vector3d half_cosine(double t, double t0, double t1, double a, double b) {
  if (t <= t0) return {a, 0.0, 0.0};
  if (t >= t1) return {b, 0.0, 0.0};
  const double w = std::numbers::pi / (t1 - t0);
  const double phase = w * (t - t0);
  const double half = 0.5 * (b - a);
  return {a + half * (1.0 - std::cos(phase)), half * w * std::sin(phase),
          half * w * w * std::cos(phase)};
}

}  // namespace

void RangeDistortion::validate() const {
  require(knee > 0.0, "knee", "must be positive");
  limits::require_in(knee, limits::kDistance, "knee");
  require(softness > 0.0, "softness", "must be positive");
  limits::require_in(softness, limits::kDistance, "softness");
}

Eigen::Vector2d RangeDistortion::apply(const Eigen::Vector2d& position) const {
  const double eta = position(1);
  if (eta <= knee) return position;
  const double eta_m = knee + softness * std::tanh((eta - knee) / softness);
  return {position(0) * eta_m / eta, eta_m};
}

void RangeSensorDataConfig::validate() const {
  distortion.validate();
  require(samples >= 10 && samples <= 10000000, "samples", "must be in [10, 10⁷]");
  require(lower.allFinite() && upper.allFinite() && (lower.array() < upper.array()).all() &&
              lower.cwiseAbs().maxCoeff() <= limits::kDistance.max &&
              upper.cwiseAbs().maxCoeff() <= limits::kDistance.max,
          "box", "lower must be below upper in ξ and η, within ±10⁹");
  require(lower(1) > 0.0, "box", "η must stay positive (ahead of the sensor)");
  limits::require_in(noise_sigma, limits::kNoiseSigma, "noise_sigma");
}

RangeSensorData simulate_range_sensor(const RangeSensorDataConfig& config) {
  config.validate();
  Rng rng(derive_seed(config.seed, 2));
  RangeSensorData data;
  data.positions.resize(config.samples, 2);
  data.outputs.resize(config.samples, 2);
  for (int q = 0; q < config.samples; ++q) {
    const Eigen::Vector2d p(rng.uniform(config.lower(0), config.upper(0)),
                            rng.uniform(config.lower(1), config.upper(1)));
    data.positions.row(q) = p.transpose();
    const Eigen::Vector2d m = config.distortion.apply(p);
    data.outputs.row(q) << m(0) + rng.normal(0.0, config.noise_sigma),
        m(1) + rng.normal(0.0, config.noise_sigma);
  }
  return data;
}

void CutInScenario::validate() const {
  distortion.validate();
  limits::require_in(sample_period, limits::kSamplePeriod, "sample_period");
  require(steps >= 2 && steps <= 10000000, "steps", "must be in [2, 10⁷]");
  limits::require_magnitude(host_speed, limits::kSpeed, "host_speed");
  limits::require_magnitude(target_speed, limits::kSpeed, "target_speed");
  limits::require_magnitude(lane_offset, limits::kDistance, "lane_offset");
  limits::require_magnitude(initial_gap, limits::kDistance, "initial_gap");
  limits::require_in(cut_in_start, limits::kDuration, "cut_in");
  limits::require_in(cut_in_end, limits::kDuration, "cut_in");
  limits::require_in(return_start, limits::kDuration, "return");
  limits::require_in(return_end, limits::kDuration, "return");
  require(cut_in_start < cut_in_end && cut_in_end <= return_start && return_start < return_end,
          "cut_in", "needs cut_in_start < cut_in_end ≤ return_start < return_end");
  const Eigen::Matrix2d& R = measurement_covariance;
  require(R.allFinite() && R(0, 0) > 0.0 && R.determinant() > 0.0 &&
              R.cwiseAbs().maxCoeff() <= limits::kVariance.max,
          "measurement_covariance", "must be positive definite, entries within 10¹⁸");
  require(runs >= 1, "runs", "must be positive");
}

CutInData simulate_cut_in(const CutInScenario& s) {
  s.validate();
  CutInData data;
  data.truth.resize(s.steps, 6);
  const double relative_speed = s.target_speed - s.host_speed;
  for (int k = 0; k < s.steps; ++k) {
    const double t = k * s.sample_period;
    const Eigen::Vector3d lateral =
        t < s.return_start ? half_cosine(t, s.cut_in_start, s.cut_in_end, s.lane_offset, 0.0)
                           : half_cosine(t, s.return_start, s.return_end, 0.0, s.lane_offset);
    data.truth.row(k) << lateral(0), lateral(1), lateral(2), s.initial_gap + relative_speed * t,
        relative_speed, 0.0;
  }
  const Eigen::LLT<Eigen::Matrix2d> llt(s.measurement_covariance);
  const Eigen::Matrix2d L = llt.matrixL();
  for (int run = 0; run < s.runs; ++run) {
    Rng rng(derive_seed(s.seed, static_cast<std::uint64_t>(run)));
    Eigen::MatrixXd z(s.steps, 2);
    for (int k = 0; k < s.steps; ++k) {
      const Eigen::Vector2d clean =
          s.distortion.apply(Eigen::Vector2d(data.truth(k, 0), data.truth(k, 3)));
      const Eigen::Vector2d noise(rng.normal(), rng.normal());
      z.row(k) = (clean + L * noise).transpose();
    }
    data.measurements.push_back(std::move(z));
  }
  return data;
}

}  // namespace imm::datasets
