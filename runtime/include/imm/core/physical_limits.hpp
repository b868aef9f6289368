// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The ranges every physical quantity must lie in — in a filter spec, a model file, a trainer
/// config or a scenario — and the check that names the offending field.
///
/// "Finite" is not enough: a sample period of 1e-320 s or a σ of 1e308 is finite, but T⁴, 1/T or
/// σ² overflow or underflow deep inside a filter or a trainer, where the error no longer says
/// which key to fix. The bounds below are wide enough for every sensor and target in either unit
/// system the configs use (m or km, s) and narrow enough that products of in-range values — a
/// variance q T⁴, a position v t over a whole track, σ² of a sum of outputs — stay far inside the
/// double range.

#include <Eigen/Core>
#include <cmath>
#include <sstream>
#include <string>
#include <string_view>

#include "imm/core/invalid_parameter.hpp"
#include "imm/runtime_export.hpp"

namespace imm::limits {

/// A closed interval [min, max] with its unit (for the error message).
struct IMM_RUNTIME_EXPORT Interval {
  /// Lower bound (inclusive).
  double min;
  /// Upper bound (inclusive).
  double max;
  /// Unit printed after the interval ("" when it depends on the config).
  std::string_view unit;
  /// Whether min ≤ value ≤ max (false for NaN).
  [[nodiscard]] constexpr bool contains(double value) const { return value >= min && value <= max; }
};

/// Sample periods, time constants, durations: a microsecond to ten hours.
inline constexpr Interval kSamplePeriod{1e-6, 36000.0, "s"};
/// Time constants (Singer τ, FCM windows in time): a microsecond to 10⁷ s.
inline constexpr Interval kTimeConstant{1e-6, 1e7, "s"};
/// Durations (maneuvers, scenarios): 0 to 10⁷ s.
inline constexpr Interval kDuration{0.0, 1e7, "s"};
/// Standard deviations of measurements, sensors and truth noise (m, km, rad): strictly positive
/// where they divide (σ² must not underflow to 0) ...
inline constexpr Interval kSigma{1e-9, 1e9, ""};
/// ... and non-negative where zero is meaningful (noise-free truth).
inline constexpr Interval kNoiseSigma{0.0, 1e9, ""};
/// Variances and process-noise intensities (q, σ², in the config's squared units).
inline constexpr Interval kVariance{0.0, 1e18, ""};
/// Positions, ranges and distances (m or km).
inline constexpr Interval kDistance{0.0, 1e9, ""};
/// Speeds, as magnitudes (m/s or km/s).
inline constexpr Interval kSpeed{0.0, 1e6, ""};
/// Accelerations, as magnitudes (m/s² or km/s²).
inline constexpr Interval kAcceleration{0.0, 1e6, ""};
/// Turn rates as magnitudes, rad/s (a regime file's `rate_deg` is held to the same bound in °/s).
inline constexpr Interval kTurnRate{0.0, 1e3, "rad/s"};
/// A coordinated-turn mode's turn-rate noise: rad²/s⁴ per period (piecewise) or rad²/s³ (PSD).
inline constexpr Interval kTurnRateNoise{0.0, 1e2, ""};
/// The prior variance of a turn rate, rad²/s² (10 rad/s, 570 °/s, as one standard deviation).
inline constexpr Interval kTurnRateVariance{0.0, 1e2, "rad^2/s^2"};
/// Dimensionless positive factors and ratios (scales, separations, fuzzifiers).
inline constexpr Interval kFactor{0.0, 1e6, ""};

/// The largest magnitude of a measurement component a filter accepts (positions and ranges in m
/// or km, azimuths in rad, sensor outputs): a plot beyond it is a broken sensor or a corrupt file,
/// not a target, and its square would overflow deep inside an update (ν² / S, d dᵀ in the mixing),
/// leaving a non-finite or indefinite estimate instead of an error.
inline constexpr double kMaxMeasurement = kDistance.max;

/// Whether a measurement component is usable: finite and within ±kMaxMeasurement (false for NaN).
[[nodiscard]] inline bool usable_measurement(double value) {
  return std::abs(value) <= kMaxMeasurement;
}
/// Whether every component of a measurement is usable (see the scalar overload).
template <class Derived>
[[nodiscard]] bool usable_measurement(const Eigen::DenseBase<Derived>& z) {
  return (z.derived().array().abs() <= kMaxMeasurement).all();
}

/// "[1e-06, 36000] s"
[[nodiscard]] inline std::string describe(const Interval& interval) {
  std::ostringstream text;
  text << '[' << interval.min << ", " << interval.max << ']';
  if (!interval.unit.empty()) text << ' ' << interval.unit;
  return text.str();
}

/// Whether `value` is finite and lies in `interval`.
[[nodiscard]] inline bool contains(const Interval& interval, double value) {
  return std::isfinite(value) && value >= interval.min && value <= interval.max;
}

/// Throws InvalidParameter(field, "must be in [min, max] unit") unless `value` lies in `interval`.
inline void require_in(double value, const Interval& interval, const std::string& field) {
  require(contains(interval, value), field, "must be in " + describe(interval));
}

/// The sample period T of a spec: unset (0, every spec's default) is refused as such, since a
/// spec's period comes from its regime or its model file, never from a default; otherwise as
/// require_in with kSamplePeriod.
inline void require_sample_period(double value, const std::string& field) {
  require(value != 0.0, field, "is not set: it comes from the regime or the model file");
  require_in(value, kSamplePeriod, field);
}

/// The same for |value| (signed positions, velocities, accelerations).
inline void require_magnitude(double value, const Interval& interval, const std::string& field) {
  require(std::isfinite(value) && std::abs(value) <= interval.max, field,
          "must be in " + describe({-interval.max, interval.max, interval.unit}));
}

}  // namespace imm::limits
