// SPDX-License-Identifier: Apache-2.0
#include "imm/datasets/regime.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "imm/core/enum_names.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/datasets/random.hpp"
#include "imm/datasets/recorded.hpp"
#include "imm/datasets/sampled_sensor.hpp"

namespace imm::datasets {
namespace {

// Streams of splits.seed for the training and validation splits (the test split uses the
// evaluation's seed itself).
constexpr std::uint64_t kTrainingStream = 0x7452'4149'4e00ULL;
constexpr std::uint64_t kValidationStream = 0x7641'4c49'4400ULL;

// Angles are held in radians and written in degrees (the keys ending in _deg): they are checked,
// and a refusal states its bounds, in the key's unit.
constexpr limits::Interval kAngleDegrees{-100.0 / kRadiansPerDegree, 100.0 / kRadiansPerDegree,
                                         "°"};
constexpr limits::Interval kAzimuthSigmaDegrees{1e-9 / kRadiansPerDegree, 3.2 / kRadiansPerDegree,
                                                "°"};
constexpr limits::Interval kTurnRateDegrees{0.0, limits::kTurnRate.max / kRadiansPerDegree, "°/s"};

Interval in_degrees(const Interval& radians) {
  return {radians.min / kRadiansPerDegree, radians.max / kRadiansPerDegree, radians.log};
}

void check_interval(const Interval& interval, const limits::Interval& range,
                    const std::string& field) {
  limits::require_in(interval.min, range, field);
  limits::require_in(interval.max, range, field);
  require(interval.min <= interval.max, field, "must be [min, max] with min ≤ max");
  require(!interval.log || interval.min > 0.0, field, "a log-uniform interval needs min > 0");
}

void check_noise(SensorKind kind, const SensorNoise& noise, const std::string& prefix) {
  if (kind == SensorKind::kPolar) {
    limits::require_in(noise.sigma(0), limits::kSigma, prefix + "range_sigma");
    limits::require_in(noise.sigma(1) / kRadiansPerDegree, kAzimuthSigmaDegrees,
                       prefix + "azimuth_sigma_deg");
    return;
  }
  limits::require_in(noise.sigma(0), limits::kSigma, prefix + "sigma");
  limits::require_in(noise.sigma(1), limits::kSigma, prefix + "sigma");
  require(std::isfinite(noise.correlation) && std::abs(noise.correlation) < 1.0,
          prefix + "correlation", "must be in (-1, 1)");
}

void check_start(const Start& s, const std::string& prefix) {
  if (s.fixed) {
    for (Eigen::Index i = 0; i < 2; ++i) {
      limits::require_magnitude(s.position(i), limits::kDistance, prefix + "position");
      limits::require_magnitude(s.velocity(i), limits::kSpeed, prefix + "velocity");
    }
    return;
  }
  check_interval(s.range, limits::kDistance, prefix + "range");
  check_interval(in_degrees(s.bearing), kAngleDegrees, prefix + "bearing_deg");
  check_interval(s.speed, limits::kSpeed, prefix + "speed");
  check_interval(in_degrees(s.heading), kAngleDegrees,
                 prefix + (s.inbound ? "heading_offset_deg" : "heading_deg"));
}

}  // namespace

constexpr std::array kUnitsNames{EnumName<Units>{Units::kMetres, "m"},
                                 EnumName<Units>{Units::kKilometres, "km"}};
constexpr std::array kSensorKindNames{
    EnumName<SensorKind>{SensorKind::kCartesian, "cartesian"},
    EnumName<SensorKind>{SensorKind::kPolar, "polar"},
    EnumName<SensorKind>{SensorKind::kRangeSensor, "range_sensor"}};
constexpr std::array kSegmentKindNames{
    EnumName<SegmentKind>{SegmentKind::kConstantVelocity, "cv"},
    EnumName<SegmentKind>{SegmentKind::kConstantAcceleration, "ca"},
    EnumName<SegmentKind>{SegmentKind::kTurn, "turn"},
    EnumName<SegmentKind>{SegmentKind::kZigzag, "zigzag"},
    EnumName<SegmentKind>{SegmentKind::kLaneChange, "lane_change"}};
constexpr std::array kDirectionNames{EnumName<Direction>{Direction::kAlong, "along"},
                                     EnumName<Direction>{Direction::kLateral, "lateral"},
                                     EnumName<Direction>{Direction::kAny, "any"},
                                     EnumName<Direction>{Direction::kAxis, "axis"}};
constexpr std::array kSplitNames{EnumName<Split>{Split::kTraining, "training"},
                                 EnumName<Split>{Split::kValidation, "validation"},
                                 EnumName<Split>{Split::kTest, "test"}};

std::string_view to_string(Units units) { return name_of(kUnitsNames, units); }

std::string_view to_string(SensorKind kind) { return name_of(kSensorKindNames, kind); }

std::string_view to_string(SegmentKind kind) { return name_of(kSegmentKindNames, kind); }

std::string_view to_string(Direction direction) { return name_of(kDirectionNames, direction); }

std::string_view to_string(Split split) { return name_of(kSplitNames, split); }

Split split_named(std::string_view name, const std::string& field) {
  return value_named(kSplitNames, name, field, "split");
}

Units units_named(std::string_view name, const std::string& field) {
  return value_named(kUnitsNames, name, field, "unit");
}

SensorKind sensor_kind_named(std::string_view name, const std::string& field) {
  return value_named(kSensorKindNames, name, field, "sensor kind");
}

double Interval::draw(Rng& rng) const {
  if (min == max) return min;
  if (log) return std::exp(rng.uniform(std::log(min), std::log(max)));
  return rng.uniform(min, max);
}

Eigen::Matrix2d SensorNoise::covariance() const {
  const double c = correlation * sigma(0) * sigma(1);
  Eigen::Matrix2d R;
  R << sigma(0) * sigma(0), c, c, sigma(1) * sigma(1);
  return R;
}

Eigen::Vector2d Sensor::response(const Eigen::Vector2d& at) const {
  if (kind != SensorKind::kRangeSensor) return at;
  return sampled ? sampled->response(at) : distortion.apply(at);
}

int Regime::case_count() const { return cases.empty() ? 1 : static_cast<int>(cases.size()); }

const std::string& Regime::case_name(int index) const {
  static const std::string no_name;
  return cases.empty() ? no_name : cases[static_cast<std::size_t>(index)].name;
}

const SensorNoise& Regime::noise_of(int case_index) const {
  if (cases.empty()) return sensor.noise;
  const auto& c = cases[static_cast<std::size_t>(case_index)];
  return c.noise ? *c.noise : sensor.noise;
}

namespace {

void validate_splits(const Splits& splits) {
  require(splits.training >= 1 && splits.training <= kMaxSplitTracks, "splits.training",
          "must be in [1, 10⁶]");
  require(splits.validation >= 1 && splits.validation <= kMaxSplitTracks, "splits.validation",
          "must be in [1, 10⁶]");
  require(splits.test >= 1 && splits.test <= kMaxSplitTracks, "splits.test", "must be in [1, 10⁶]");
}

}  // namespace

double Regime::max_speed() const {
  double speed = start.fixed ? start.velocity.norm() : start.speed.max;
  for (const auto& c : cases) {
    if (c.start)
      speed = std::max(speed, c.start->fixed ? c.start->velocity.norm() : c.start->speed.max);
  }
  return speed;
}

namespace {

// Commanded acceleration magnitudes of a regime: (largest, smallest positive).
std::pair<double, double> acceleration_range(const Regime& r) {
  double largest = 0.0, smallest = std::numeric_limits<double>::infinity();
  auto add = [&](double a) {
    a = std::abs(a);
    if (!(a > 0.0)) return;
    largest = std::max(largest, a);
    smallest = std::min(smallest, a);
  };
  const double speed = r.max_speed();
  auto lane_peak = [](double offset, double duration) {
    // Half-cosine: peak |a| = |offset|/2 (π/τ)².
    const double w = std::numbers::pi / duration;
    return 0.5 * std::abs(offset) * w * w;
  };
  for (const MenuEntry& e : r.menu) {
    switch (e.kind) {
      case SegmentKind::kConstantAcceleration:
      case SegmentKind::kZigzag:
        add(e.magnitude.min);
        add(e.magnitude.max);
        break;
      case SegmentKind::kTurn:
        add(e.rate.min * speed);
        add(e.rate.max * speed);
        break;
      case SegmentKind::kLaneChange:
        if (e.duration.min > 0.0) add(lane_peak(e.magnitude.max, e.duration.min));
        if (e.duration.max > 0.0) add(lane_peak(e.magnitude.min, e.duration.max));
        break;
      case SegmentKind::kConstantVelocity:
        break;
    }
  }
  for (const ScriptedCase& c : r.cases) {
    for (const ScriptedSegment& s : c.segments) {
      switch (s.kind) {
        case SegmentKind::kConstantAcceleration:
          add(s.acceleration.norm());
          break;
        case SegmentKind::kZigzag:
          for (double a : s.amplitudes) add(a);
          break;
        case SegmentKind::kTurn:
          add(s.rate * speed);
          break;
        case SegmentKind::kLaneChange:
          if (s.end > s.start) add(lane_peak(s.offset, s.end - s.start));
          break;
        case SegmentKind::kConstantVelocity:
          break;
      }
    }
  }
  return {largest, std::isfinite(smallest) ? smallest : 0.0};
}

}  // namespace

double Regime::max_acceleration() const {
  return recorded ? recorded->max_acceleration : acceleration_range(*this).first;
}
double Regime::min_acceleration() const {
  return recorded ? recorded->min_acceleration : acceleration_range(*this).second;
}

double Regime::position_sigma() const {
  double sigma = 0.0;
  for (int c = 0; c < case_count(); ++c) {
    const SensorNoise& n = noise_of(c);
    if (sensor.kind == SensorKind::kPolar) {
      double range = start.fixed ? (start.position - sensor.position).norm() : start.range.max;
      if (recorded) range = recorded_max_range(*recorded->set);
      sigma = std::max({sigma, n.sigma(0), n.sigma(1) * range});
    } else {
      sigma = std::max({sigma, n.sigma(0), n.sigma(1)});
    }
  }
  return sigma;
}

void SceneSpec::validate() const {
  require(targets >= 1 && targets <= 100, "scene.targets", "must be in [1, 100]");
  require(detection_probability > 0.0 && detection_probability <= 1.0,
          "scene.detection_probability", "must be in (0, 1]");
  require(clutter_per_scan >= 0.0 && clutter_per_scan <= 1e4, "scene.clutter_per_scan",
          "must be in [0, 10⁴] false plots per scan");
}

void Regime::validate() const {
  require(!name.empty(), "name", "must not be empty");
  scene.validate();
  limits::require_in(sample_period, limits::kSamplePeriod, "sample_period");
  require(scans >= 3 && scans <= 1'000'000, "scans", "must be in [3, 10⁶]");
  limits::require_in(process_noise_sigma, limits::kAcceleration, "process_noise_sigma");
  check_noise(sensor.kind, sensor.noise, "sensor.");
  if (recorded) {  // no generator: the splits are the only other keys (test may be empty)
    require(splits.test >= 0, "splits.test", "must be in [0, 10⁶]");
    Splits checked = splits;
    checked.test = std::max(1, splits.test);
    validate_splits(checked);
    return;
  }
  for (Eigen::Index i = 0; i < 2; ++i) {
    limits::require_magnitude(sensor.position(i), limits::kDistance, "sensor.position");
  }
  if (sensor.kind == SensorKind::kRangeSensor) {
    if (!sensor.sampled) {
      validate_within("sensor.", sensor.distortion);
    }
    const SensorCalibration& c = sensor.calibration;
    require(c.samples >= 10 && c.samples <= 10'000'000, "sensor.calibration.samples",
            "must be in [10, 10⁷]");
    require(c.lower.allFinite() && c.upper.allFinite() &&
                (c.lower.array() < c.upper.array()).all() &&
                c.lower.cwiseAbs().maxCoeff() <= limits::kDistance.max &&
                c.upper.cwiseAbs().maxCoeff() <= limits::kDistance.max && c.lower(1) > 0.0,
            "sensor.calibration.box",
            "must be [[ξ_min, η_min], [ξ_max, η_max]] with min < max and η_min > 0");
    limits::require_in(c.noise_sigma, limits::kNoiseSigma, "sensor.calibration.noise_sigma");
  }
  check_start(start, "start.");
  require(!menu.empty() || !cases.empty(), "maneuvers",
          "a regime needs a maneuver menu ([[maneuvers]]) or scripted cases ([[cases]])");
  require(menu.empty() || cases.empty(), "cases",
          "a regime has either a maneuver menu or scripted cases, not both");
  double total = 0.0;
  for (std::size_t i = 0; i < menu.size(); ++i) {
    const MenuEntry& e = menu[i];
    const std::string field = "maneuvers[" + std::to_string(i) + "].";
    require(std::isfinite(e.probability) && e.probability > 0.0 && e.probability <= 1.0,
            field + "probability", "must be in (0, 1]");
    total += e.probability;
    if (e.kind != SegmentKind::kZigzag) {
      check_interval(e.duration, limits::kDuration, field + "duration");
      require(e.duration.min > 0.0, field + "duration", "must be positive");
    }
    switch (e.kind) {
      case SegmentKind::kConstantAcceleration:
        check_interval(e.magnitude, limits::kAcceleration, field + "magnitude");
        break;
      case SegmentKind::kTurn:
        check_interval(in_degrees(e.rate), kTurnRateDegrees, field + "rate_deg");
        break;
      case SegmentKind::kZigzag:
        check_interval(e.magnitude, limits::kAcceleration, field + "magnitude");
        check_interval(e.quarter, limits::kDuration, field + "quarter");
        require(e.quarter.min >= sample_period, field + "quarter",
                "must last at least one sample period");
        require(e.min_periods >= 1 && e.max_periods >= e.min_periods && e.max_periods <= 1000,
                field + "periods", "must be [min, max] with 1 ≤ min ≤ max ≤ 1000");
        break;
      case SegmentKind::kLaneChange:
        check_interval(e.magnitude, limits::kDistance, field + "offset");
        break;
      case SegmentKind::kConstantVelocity:
        break;
    }
  }
  require(menu.empty() || std::abs(total - 1.0) <= 1e-9, "maneuvers",
          "the probabilities sum to " + std::to_string(total) + ", not 1");
  const double duration = sample_period * (scans - 1);
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const ScriptedCase& c = cases[i];
    const std::string field = "cases[" + std::to_string(i) + "].";
    require(!c.name.empty(), field + "name", "must not be empty");
    for (std::size_t j = 0; j < i; ++j) {
      require(cases[j].name != c.name, field + "name", "'" + c.name + "' is repeated");
    }
    if (c.start) check_start(*c.start, field + "start.");
    if (c.noise) check_noise(sensor.kind, *c.noise, field);
    for (std::size_t j = 0; j < c.segments.size(); ++j) {
      const ScriptedSegment& s = c.segments[j];
      const std::string sf = field + "segments[" + std::to_string(j) + "].";
      limits::require_in(s.start, {0.0, duration, "s"}, sf + "start");
      if (s.kind == SegmentKind::kZigzag) {
        require(!s.amplitudes.empty() && s.amplitudes.size() <= 1000, sf + "amplitudes",
                "need 1 to 1000 periods");
        for (double a : s.amplitudes)
          limits::require_in(a, limits::kAcceleration, sf + "amplitudes");
        require(s.quarter >= sample_period && s.quarter <= limits::kDuration.max, sf + "quarter",
                "must last at least one sample period");
        continue;
      }
      require(std::isfinite(s.end) && s.end > s.start && s.end <= limits::kDuration.max, sf + "end",
              "must be after start");
      switch (s.kind) {
        case SegmentKind::kConstantAcceleration:
          for (Eigen::Index a = 0; a < 2; ++a) {
            limits::require_magnitude(s.acceleration(a), limits::kAcceleration,
                                      sf + "acceleration");
          }
          break;
        case SegmentKind::kTurn:
          limits::require_magnitude(s.rate / kRadiansPerDegree, kTurnRateDegrees, sf + "rate_deg");
          break;
        case SegmentKind::kLaneChange:
          limits::require_magnitude(s.offset, limits::kDistance, sf + "offset");
          break;
        default:
          break;
      }
    }
  }
  validate_splits(splits);
}

std::uint64_t track_seed(const Regime& regime, Split split, int index, std::uint64_t test_seed) {
  const auto i = static_cast<std::uint64_t>(index);
  switch (split) {
    case Split::kTraining:
      return derive_seed(derive_seed(regime.splits.seed, kTrainingStream), i);
    case Split::kValidation:
      return derive_seed(derive_seed(regime.splits.seed, kValidationStream), i);
    case Split::kTest:
      return derive_seed(test_seed, i);
  }
  return 0;
}

int split_size(const Regime& regime, Split split) {
  if (regime.recorded) return recorded_split_size(regime, split);
  switch (split) {
    case Split::kTraining:
      return regime.splits.training;
    case Split::kValidation:
      return regime.splits.validation;
    case Split::kTest:
      return regime.splits.test;
  }
  return 0;
}

}  // namespace imm::datasets
