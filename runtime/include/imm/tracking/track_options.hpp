// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// How a Tracker (tracker.hpp) feeds a filter: the measurement space of the plots, their noise, the
/// track start and when a gap ends a track. Every filter spec of the runtime has
/// `track_options(max_gap)` returning the options it was trained and evaluated with, and
/// load_tracker() (imm/load.hpp) uses them.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <string_view>

#include "imm/runtime_export.hpp"
#include "imm/tracking/envelope.hpp"

namespace imm {

/// The plots' space: Cartesian [x, y] or polar [range, azimuth (rad, clockwise from the y axis)].
enum class MeasurementKind { kCartesian, kPolar };
/// How a track starts: from an explicit Gaussian or from its first two plots.
enum class InitializationMethod { kExplicit, kTwoPoint };

[[nodiscard]] IMM_RUNTIME_EXPORT std::string_view to_string(
    MeasurementKind kind);  ///< "cartesian", "polar"
[[nodiscard]] IMM_RUNTIME_EXPORT std::string_view to_string(
    InitializationMethod method);  ///< "explicit", "two_point"
/// Inverse of to_string; throw InvalidParameter naming `field` for unknown names.
[[nodiscard]] IMM_RUNTIME_EXPORT MeasurementKind measurement_kind_from(std::string_view name,
                                                                       const std::string& field);
/// "explicit" | "two_point"; InvalidParameter naming `field` otherwise.
[[nodiscard]] IMM_RUNTIME_EXPORT InitializationMethod
initialization_method_from(std::string_view name, const std::string& field);

/// How a Tracker starts a track.
struct IMM_RUNTIME_EXPORT InitializationSpec {
  /// kTwoPoint: position from the second valid plot, velocity from the difference of the first
  /// two; kExplicit: `state`/`covariance` are the estimate one period before the first plot.
  InitializationMethod method = InitializationMethod::kTwoPoint;
  Eigen::VectorXd state;               ///< explicit: the filter's state layout
  Eigen::MatrixXd covariance;          ///< explicit: the filter's state layout
  double acceleration_variance = 0.0;  ///< two-point, 6-state: variance of ax and ay
  /// Two-point, a state with a turn rate (a CT mode): the variance of ω (rad²/s²) about 0.
  double turn_rate_variance = 0.0;
};

/// Gaps longer than this many scans end a track unless the options say otherwise.
inline constexpr std::int64_t kDefaultMaxGap = 50;

/// How a Tracker runs a filter: the scan period, the plots' kind and R, the start and the longest
/// gap.
struct IMM_RUNTIME_EXPORT TrackOptions {
  double sample_period = 0.0;  ///< T, s: one scan (unset: from the model or the regime)
  /// Cartesian or polar plots.
  MeasurementKind measurement_kind = MeasurementKind::kCartesian;
  /// R of one plot: Cartesian [x, y] or polar [range, azimuth (rad)].
  Eigen::Matrix2d measurement_covariance = Eigen::Matrix2d::Identity();
  /// How a track starts.
  InitializationSpec initialization;
  /// Gaps longer than this many scans end the track; the next plot starts a new one.
  std::int64_t max_gap = kDefaultMaxGap;
  /// The envelope test of the plots (envelope.hpp): the model file's, or the defaults.
  EnvelopeSettings envelope;
};

/// The options of a filter started from two plots (every spec but an explicit plain IMM): plots of
/// `kind` with covariance R; `acceleration_variance` is the start's ax, ay variance (6-state).
[[nodiscard]] inline TrackOptions two_point_track_options(double sample_period,
                                                          MeasurementKind kind,
                                                          const Eigen::Matrix2d& R,
                                                          std::int64_t max_gap,
                                                          double acceleration_variance = 0.0) {
  TrackOptions options;
  options.sample_period = sample_period;
  options.measurement_kind = kind;
  options.measurement_covariance = R;
  options.initialization.method = InitializationMethod::kTwoPoint;
  options.initialization.acceleration_variance = acceleration_variance;
  options.max_gap = max_gap;
  return options;
}

}  // namespace imm
