#pragma once
/// A single track run by a plain IMM over a stream of scan-indexed 2-D plots: initializes the
/// track (two-point or explicit), predicts through scans without a usable plot, and rejects bad
/// plots without touching the filter. What `imm-track` runs, and what a tracking application
/// wants around an ImmEstimator.

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string_view>

#include "imm/filters/plain_imm.hpp"

namespace imm {

enum class TrackEvent {
  kWaiting,      ///< first plot of a two-point initialization stored; no estimate yet
  kInitialized,  ///< the track was started at this scan
  kUpdated,      ///< an IMM cycle with this plot (after predicting through any skipped scans)
  kRejected,     ///< the plot was not used (scans skipped before it may have been predicted)
};

[[nodiscard]] std::string_view to_string(TrackEvent event);

struct TrackStepResult {
  TrackEvent event = TrackEvent::kWaiting;
  StepStatus status = StepStatus::kOk;  ///< why a plot was rejected (kOk otherwise)
  std::int64_t predicted_scans = 0;     ///< scans predicted through without a plot
  std::string_view reason;              ///< human-readable reason for a rejection
};

class PlainImmTracker {
 public:
  /// Gaps longer than this many scans end the track; the next plot starts a new one.
  static constexpr std::int64_t kDefaultMaxGap = 50;

  explicit PlainImmTracker(const PlainImmSpec& spec, std::int64_t max_gap = kDefaultMaxGap);

  /// Feeds the plot of `scan`. Scans must increase; skipped scans are predicted through. A plot
  /// with NaN/Inf or a repeated or decreasing scan is rejected and leaves the track unchanged; a
  /// plot the IMM cannot use (singular S) is rejected after the skipped scans were predicted.
  TrackStepResult process(std::int64_t scan, const Eigen::Vector2d& z);

  [[nodiscard]] bool initialized() const { return initialized_; }
  [[nodiscard]] int state_dimension() const { return spec_.mixing_dimension(); }
  [[nodiscard]] int mode_count() const { return static_cast<int>(spec_.modes.size()); }
  [[nodiscard]] const PlainImmSpec& spec() const { return spec_; }
  [[nodiscard]] std::optional<std::int64_t> last_scan() const { return last_scan_; }

  /// Combined mean and covariance diagonal, state_dimension() entries each (initialized only).
  void state(Eigen::Ref<Eigen::VectorXd> mean, Eigen::Ref<Eigen::VectorXd> variance) const;
  [[nodiscard]] ModeVector mode_probabilities() const;

 private:
  struct Plot {
    std::int64_t scan = 0;
    Eigen::Vector2d position = Eigen::Vector2d::Zero();
    Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();
  };

  [[nodiscard]] Plot cartesian_plot(std::int64_t scan, const Eigen::Vector2d& z) const;
  void start_track(const Plot& first, const Plot& second);

  PlainImmSpec spec_;
  PlainImm imm_;
  std::int64_t max_gap_;
  std::optional<Plot> first_plot_;
  std::optional<std::int64_t> last_scan_;
  bool initialized_ = false;
};

}  // namespace imm
