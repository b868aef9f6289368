// SPDX-License-Identifier: Apache-2.0
// A TrackFilter driven by time stamps (track_filter.hpp): any interval for a filter whose model
// does not depend on the sample period, whole numbers of periods for any other.
#include <cmath>

#include "imm/core/physical_limits.hpp"
#include "imm/tracking/track_filter.hpp"

namespace imm {
namespace {

// Brings the filter to one cycle before the interval's end: the interval set (a filter that
// takes any), or the whole periods but the last predicted without a plot. kOk or why not.
StepStatus advance_to_last_cycle(TrackFilter& filter, double period, double interval) {
  if (filter.takes_any_interval()) {
    return filter.set_interval(interval) ? StepStatus::kOk : StepStatus::kUnsupportedInterval;
  }
  const std::int64_t periods = whole_periods(interval, period);
  if (periods == 0) return StepStatus::kUnsupportedInterval;
  for (std::int64_t k = 1; k < periods; ++k) {
    const StepStatus status = filter.predict_only();
    if (status != StepStatus::kOk) return status;
  }
  return StepStatus::kOk;
}

}  // namespace

std::int64_t whole_periods(double interval, double period) {
  if (!limits::kSamplePeriod.contains(period) || !(interval > 0.0) ||
      !(interval <= limits::kSamplePeriod.max)) {
    return 0;
  }
  const double periods = std::round(interval / period);
  if (periods < 1.0 || std::abs(interval - periods * period) > kIntervalTolerance * period) {
    return 0;
  }
  return static_cast<std::int64_t>(periods);
}

StepStatus step_over(TrackFilter& filter, double period, double interval,
                     const Eigen::Vector2d& z) {
  const StepStatus status = advance_to_last_cycle(filter, period, interval);
  return status == StepStatus::kOk ? filter.step(z) : status;
}

StepStatus predict_only_over(TrackFilter& filter, double period, double interval) {
  const StepStatus status = advance_to_last_cycle(filter, period, interval);
  return status == StepStatus::kOk ? filter.predict_only() : status;
}

StepStatus predict_over(TrackFilter& filter, double period, double interval) {
  // A filter that does not split its cycle refuses (TrackFilter::predict) before anything moves.
  if (!filter.has_split_cycle()) return filter.predict();
  const StepStatus status = advance_to_last_cycle(filter, period, interval);
  return status == StepStatus::kOk ? filter.predict() : status;
}

}  // namespace imm
