// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// A single track over a stream of scan-indexed 2-D plots, around any TrackFilter: starts the track
/// (two-point or explicit), predicts through scans without a usable plot, and rejects bad plots
/// without touching the filter. What `imm-track` and the evaluations run, and what a tracking
/// application wants around a filter.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <string_view>

#include "imm/filters/plain_imm.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/envelope.hpp"
#include "imm/tracking/track_filter.hpp"
#include "imm/tracking/track_options.hpp"

namespace imm {

/// What Tracker::process did with a plot.
enum class TrackEvent {
  kWaiting,      ///< first plot of a two-point initialization stored; no estimate yet
  kInitialized,  ///< the track was started at this scan
  kUpdated,      ///< a filter cycle with this plot (after predicting through any skipped scans)
  kRejected,     ///< the plot was not used (scans skipped before it may have been predicted)
};

/// "waiting", "initialized", "updated" or "rejected".
[[nodiscard]] IMM_RUNTIME_EXPORT std::string_view to_string(TrackEvent event);

/// The outcome of one Tracker::process call.
struct IMM_RUNTIME_EXPORT TrackStepResult {
  /// What happened to the plot.
  TrackEvent event = TrackEvent::kWaiting;
  StepStatus status = StepStatus::kOk;  ///< why a plot was rejected (kOk otherwise)
  std::int64_t predicted_scans = 0;     ///< scans predicted through without a plot
  std::string_view reason;              ///< human-readable reason for a rejection
  /// Whether the last `envelope.window` updates' NIS sum is outside its χ² bounds: the plots no
  /// longer fit the model (envelope.hpp). False until a window is full; kept through rejections.
  bool outside_envelope = false;
  /// The mean NIS of the window so far (2 for a consistent filter; NaN before the first update).
  double envelope_nis = 0.0;
};

/// Drives a TrackFilter through a sequence of scans: starts the track (two-point or explicit),
/// predicts through missing scans, rejects unusable plots without touching the estimate, and ends a
/// track after too long a gap.
class IMM_RUNTIME_EXPORT Tracker {
 public:
  /// Gaps longer than this many scans end a track by default.
  static constexpr std::int64_t kDefaultMaxGap = imm::kDefaultMaxGap;

  /// Throws InvalidParameter for invalid options.
  Tracker(std::unique_ptr<TrackFilter> filter, TrackOptions options);

  /// Feeds the plot of `scan`. Scans must increase; skipped scans are predicted through. A plot
  /// with NaN/Inf or a repeated or decreasing scan is rejected and leaves the track unchanged; a
  /// plot the filter cannot use (singular S) is rejected after the skipped scans were predicted.
  TrackStepResult process(std::int64_t scan, const Eigen::Vector2d& z);

  /// Feeds the plot taken at `time` s; times must increase, and a tracker is fed either scans or
  /// times. A filter that takes any interval (TrackFilter::takes_any_interval: a plain IMM without
  /// a learned schedule) predicts over the time since the last plot; any other one takes a time a
  /// whole number of sample periods after the last plot (within kIntervalTolerance), the periods
  /// between predicted through as skipped scans, and rejects another with kUnsupportedInterval,
  /// leaving the track unchanged. A gap of more than max_gap sample periods ends the track; the
  /// two-point start takes its velocity over the two plots' time difference.
  TrackStepResult process_at(double time, const Eigen::Vector2d& z);

  /// Whether a track is running.
  [[nodiscard]] bool initialized() const { return initialized_; }
  /// The filter's state dimension.
  [[nodiscard]] int state_dimension() const { return filter_->state_dimension(); }
  /// The filter's mode count.
  [[nodiscard]] int mode_count() const { return filter_->mode_count(); }
  /// The filter being driven.
  [[nodiscard]] const TrackFilter& filter() const { return *filter_; }
  /// The filter being driven (mutable).
  [[nodiscard]] TrackFilter& filter() { return *filter_; }
  /// The scan of the last accepted plot (none before the first; process() only).
  [[nodiscard]] std::optional<std::int64_t> last_scan() const {
    return clock_ == Clock::kTimes ? std::nullopt : last_scan_;
  }
  /// The time the track stands at: the last accepted plot's, or later when the periods after it
  /// were predicted through (none before the first; process_at() only).
  [[nodiscard]] std::optional<double> last_time() const { return last_time_; }

  /// Combined mean and covariance diagonal, state_dimension() entries each (initialized only).
  void state(Eigen::Ref<Eigen::VectorXd> mean, Eigen::Ref<Eigen::VectorXd> variance) const;
  /// The combined covariance, state_dimension() square (initialized only).
  void covariance(Eigen::Ref<Eigen::MatrixXd> covariance) const;
  /// The filter's mode probabilities.
  [[nodiscard]] ModeVector mode_probabilities() const { return filter_->mode_probabilities(); }
  /// The envelope test of the current track (envelope.hpp).
  [[nodiscard]] const EnvelopeMonitor& envelope() const { return envelope_; }

 private:
  struct Plot {
    std::int64_t scan = 0;
    double time = 0.0;  // s since the first plot (process_at) or the scan's (process)
    Eigen::Vector2d position = Eigen::Vector2d::Zero();
    Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();
  };
  // Whether the tracker is fed scans or times (fixed by the first plot).
  enum class Clock { kNone, kScans, kTimes };

  [[nodiscard]] Plot cartesian_plot(std::int64_t scan, double time, const Eigen::Vector2d& z) const;
  // Starts the filter from the two plots (two_point_start); false, and nothing changed, where they
  // give no finite start (plots too close in time).
  [[nodiscard]] bool start_track(const Plot& first, const Plot& second);
  // process() without the clock check (process_at of a filter of one sample period uses it, with
  // the plot's time for a two-point start).
  TrackStepResult process_scan(std::int64_t scan, double time, const Eigen::Vector2d& z);
  // process_at() of a filter that takes any interval.
  TrackStepResult process_interval(double time, const Eigen::Vector2d& z);
  // max_gap sample periods, s.
  [[nodiscard]] double longest_gap() const {
    return static_cast<double>(options_.max_gap) * options_.sample_period;
  }
  // A plot's check common to both clocks; nothing when it is usable.
  [[nodiscard]] std::optional<TrackStepResult> unusable(const Eigen::Vector2d& z) const;
  // The start of a track at this plot: an explicit start, or the first or second plot of a
  // two-point one.
  TrackStepResult start_at(std::int64_t scan, double time, const Eigen::Vector2d& z);
  TrackStepResult reject(StepStatus status, std::string_view reason) const;
  // The result with the envelope test's state.
  TrackStepResult with_envelope(TrackStepResult result) const;

  std::unique_ptr<TrackFilter> filter_;
  TrackOptions options_;
  EnvelopeMonitor envelope_;
  std::optional<Plot> first_plot_;
  std::optional<std::int64_t> last_scan_;
  std::optional<double> last_time_;
  Clock clock_ = Clock::kNone;
  bool initialized_ = false;
};

/// A track's start: the mean and covariance a filter is initialized with.
struct IMM_RUNTIME_EXPORT TrackStart {
  Eigen::VectorXd mean;        ///< the filter's state layout (state_variable_names)
  Eigen::MatrixXd covariance;  ///< its covariance
};

/// The two-point start of a track (Bar-Shalom, Li & Kirubarajan §5.5.3) from plot `first` at scan
/// `first_scan` and `second` at a later `second_scan`, in the options' measurement space (polar
/// plots converted with their covariance): position from the second plot, velocity from the
/// difference over the scans' interval; cov(p) = R₂, cov(v) = (R₁ + R₂)/Δt², cov(p, v) = R₂/Δt;
/// the options' acceleration and turn-rate variances for a 6- or odd-dimensional state. What
/// Tracker does with its first two plots. Nothing when a plot has no finite position, the
/// scans do not increase, or the start is not finite, spans less than 1 µs or is faster than
/// limits::kSpeed.
[[nodiscard]] IMM_RUNTIME_EXPORT std::optional<TrackStart> two_point_start(
    const TrackOptions& options, int state_dimension, std::int64_t first_scan,
    const Eigen::Vector2d& first, std::int64_t second_scan, const Eigen::Vector2d& second);

/// A plain IMM as a TrackFilter.
[[nodiscard]] IMM_RUNTIME_EXPORT std::unique_ptr<TrackFilter> make_plain_imm_filter(
    const PlainImmSpec& spec);

/// The track of a plain IMM spec.
class IMM_RUNTIME_EXPORT PlainImmTracker : public Tracker {
 public:
  /// Throws InvalidParameter naming the field of an invalid spec.
  explicit PlainImmTracker(const PlainImmSpec& spec, std::int64_t max_gap = kDefaultMaxGap)
      : Tracker(make_plain_imm_filter(spec), spec.track_options(max_gap)) {}
};

}  // namespace imm
