// SPDX-License-Identifier: Apache-2.0
#pragma once
// Regimes built in code for the runtime's filter tests (the TOML presets under configs/regimes are
// tested against independent references in tests/support/regime_config_test.cpp).

#include <cmath>
#include <numbers>

#include "imm/datasets/regime.hpp"
#include "imm/datasets/track.hpp"

namespace imm::testing {

// A scripted regime with one case and a fixed start.
inline datasets::Regime scripted_regime(double T, int scans, const Eigen::Vector2d& position,
                                        const Eigen::Vector2d& velocity,
                                        std::vector<datasets::ScriptedSegment> segments = {}) {
  datasets::Regime r;
  r.name = "test";
  r.sample_period = T;
  r.scans = scans;
  r.start.fixed = true;
  r.start.position = position;
  r.start.velocity = velocity;
  datasets::ScriptedCase c;
  c.name = "case";
  c.segments = std::move(segments);
  r.cases = {c};
  r.splits = {1, 1, 1, 1};
  r.validate();
  return r;
}

// Seed 004's scenarios (polar sensor σ_r 50 m, σ_θ 0.5°, T = 2 s, 250 scans, 140 km out at 45°
// inbound at 141 m/s): 1 straight, 2 with two coordinated turns of 3.82°/s.
inline datasets::Regime wimm_table2_regime(int number) {
  const double d = 140e3 / std::sqrt(2.0);
  std::vector<datasets::ScriptedSegment> turns;
  if (number == 2) {
    for (double start : {200.0, 276.0}) {
      datasets::ScriptedSegment s;
      s.kind = datasets::SegmentKind::kTurn;
      s.start = start;
      s.end = start + 24.0;
      s.rate = 3.82 * std::numbers::pi / 180.0;
      turns.push_back(s);
    }
  }
  datasets::Regime r = scripted_regime(2.0, 250, {d, d}, {-100.0, -100.0}, turns);
  r.sensor.kind = datasets::SensorKind::kPolar;
  r.sensor.noise.sigma = Eigen::Vector2d(50.0, 0.5 * std::numbers::pi / 180.0);
  return r;
}

// Seed 002's cut-in through the distorted range sensor (T = 0.1 s, 200 scans): the target starts
// beside the host at 3 m/s relative, cuts in over 1–4 s and returns over 14–18 s.
inline datasets::Regime cut_in_regime(double r_sigma, double softness = 30.0) {
  std::vector<datasets::ScriptedSegment> lanes(2);
  lanes[0].kind = lanes[1].kind = datasets::SegmentKind::kLaneChange;
  lanes[0].start = 1.0, lanes[0].end = 4.0, lanes[0].offset = 3.5;
  lanes[1].start = 14.0, lanes[1].end = 18.0, lanes[1].offset = -3.5;
  datasets::Regime r = scripted_regime(0.1, 200, {3.5, 0.0}, {0.0, 3.0}, lanes);
  r.units = datasets::Units::kMetres;
  r.sensor.kind = datasets::SensorKind::kRangeSensor;
  r.sensor.noise.sigma = Eigen::Vector2d::Constant(r_sigma);
  r.sensor.distortion.softness = softness;
  return r;
}

// Test track `index` of a regime (seed `seed`).
inline datasets::Track test_track(const datasets::Regime& regime, std::uint64_t seed,
                                  int index = 0) {
  return datasets::draw_track(regime, datasets::Split::kTest, index, seed);
}

}  // namespace imm::testing
