#include "imm/filters/plain_imm_tracker.hpp"

#include <stdexcept>

#include "imm/core/invalid_parameter.hpp"
#include "imm/models/polar_measurement.hpp"

namespace imm {

std::string_view to_string(TrackEvent event) {
  switch (event) {
    case TrackEvent::kWaiting:
      return "waiting";
    case TrackEvent::kInitialized:
      return "initialized";
    case TrackEvent::kUpdated:
      return "updated";
    case TrackEvent::kRejected:
      return "rejected";
  }
  return "?";
}

PlainImmTracker::PlainImmTracker(const PlainImmSpec& spec, std::int64_t max_gap)
    : spec_(spec), imm_(build_plain_imm(spec)), max_gap_(max_gap) {
  if (max_gap < 1) throw InvalidParameter("max_gap", "must be at least 1");
}

PlainImmTracker::Plot PlainImmTracker::cartesian_plot(std::int64_t scan,
                                                      const Eigen::Vector2d& z) const {
  Plot plot;
  plot.scan = scan;
  if (spec_.measurement.kind == MeasurementKind::kCartesian) {
    plot.position = z;
    plot.covariance = spec_.measurement.covariance;
  } else {
    const CartesianPlot converted = polar_to_cartesian(z, spec_.measurement.covariance);
    plot.position = converted.position;
    plot.covariance = converted.covariance;
  }
  return plot;
}

// Two-point initialization: position from the second plot, velocity from the difference;
// cov(p) = R₂, cov(v) = (R₁ + R₂)/Δt², cov(p, v) = R₂/Δt (Bar-Shalom, Li & Kirubarajan §5.5.3).
void PlainImmTracker::start_track(const Plot& first, const Plot& second) {
  const double dt = static_cast<double>(second.scan - first.scan) * spec_.sample_period;
  std::visit(
      [&](auto& imm) {
        constexpr int kNx = std::decay_t<decltype(imm)>::kDim;
        constexpr int kPerAxis = kNx / 2;
        GaussianState<kNx> state;
        state.mean.setZero();
        state.covariance.setZero();
        for (int axis = 0; axis < 2; ++axis) {
          const int p = axis * kPerAxis;
          state.mean(p) = second.position(axis);
          state.mean(p + 1) = (second.position(axis) - first.position(axis)) / dt;
          for (int other = 0; other < 2; ++other) {
            const int q = other * kPerAxis;
            const double r1 = first.covariance(axis, other), r2 = second.covariance(axis, other);
            state.covariance(p, q) = r2;
            state.covariance(p, q + 1) = r2 / dt;
            state.covariance(p + 1, q) = r2 / dt;
            state.covariance(p + 1, q + 1) = (r1 + r2) / (dt * dt);
          }
          if constexpr (kPerAxis == 3) {
            state.covariance(p + 2, p + 2) = spec_.initialization.acceleration_variance;
          }
        }
        imm.initialize(state);
      },
      imm_);
}

TrackStepResult PlainImmTracker::process(std::int64_t scan, const Eigen::Vector2d& z) {
  TrackStepResult result;
  if (last_scan_ && scan <= *last_scan_) {
    result.event = TrackEvent::kRejected;
    result.status = StepStatus::kInvalidMeasurement;
    result.reason = "scan index does not increase";
    return result;
  }
  if (!z.allFinite()) {
    result.event = TrackEvent::kRejected;
    result.status = StepStatus::kInvalidMeasurement;
    result.reason = "measurement is NaN or infinite";
    return result;
  }

  if (initialized_ && scan - *last_scan_ > max_gap_) {
    initialized_ = false;  // track lost: start again from this plot
    first_plot_.reset();
  }

  if (!initialized_) {
    if (spec_.initialization.method == InitializationMethod::kExplicit) {
      std::visit(
          [&](auto& imm) {
            constexpr int kNx = std::decay_t<decltype(imm)>::kDim;
            GaussianState<kNx> state;
            state.mean = spec_.initialization.state;
            state.covariance = spec_.initialization.covariance;
            imm.initialize(state);
          },
          imm_);
      const StepStatus status = std::visit([&](auto& imm) { return imm.step(z); }, imm_);
      if (status != StepStatus::kOk) {
        result.event = TrackEvent::kRejected;
        result.status = status;
        result.reason = to_string(status);
        return result;
      }
      initialized_ = true;
      last_scan_ = scan;
      result.event = TrackEvent::kInitialized;
      return result;
    }
    const Plot plot = cartesian_plot(scan, z);
    if (!plot.position.allFinite()) {
      result.event = TrackEvent::kRejected;
      result.status = StepStatus::kInvalidMeasurement;
      result.reason = "measurement is not convertible to a position";
      return result;
    }
    if (!first_plot_ || scan - first_plot_->scan > max_gap_) {
      first_plot_ = plot;
      last_scan_ = scan;
      result.event = TrackEvent::kWaiting;
      return result;
    }
    start_track(*first_plot_, plot);
    first_plot_.reset();
    initialized_ = true;
    last_scan_ = scan;
    result.event = TrackEvent::kInitialized;
    return result;
  }

  // Predict through the skipped scans, then update. If the update fails, the predictions stay:
  // the track then stands at the scan before this plot.
  const std::int64_t gap = scan - *last_scan_ - 1;
  for (std::int64_t i = 0; i < gap; ++i) {
    const StepStatus status = std::visit([](auto& imm) { return imm.predict_only(); }, imm_);
    if (status != StepStatus::kOk) {
      result.event = TrackEvent::kRejected;
      result.status = status;
      result.reason = to_string(status);
      return result;
    }
    ++result.predicted_scans;
  }
  const StepStatus status = std::visit([&](auto& imm) { return imm.step(z); }, imm_);
  last_scan_ = scan - (status == StepStatus::kOk ? 0 : 1);
  if (status != StepStatus::kOk) {
    result.event = TrackEvent::kRejected;
    result.status = status;
    result.reason = to_string(status);
    return result;
  }
  result.event = TrackEvent::kUpdated;
  return result;
}

void PlainImmTracker::state(Eigen::Ref<Eigen::VectorXd> mean,
                            Eigen::Ref<Eigen::VectorXd> variance) const {
  if (!initialized_) throw std::logic_error("PlainImmTracker::state before initialization");
  std::visit(
      [&](const auto& imm) {
        mean = imm.estimate().mean;
        variance = imm.estimate().covariance.diagonal();
      },
      imm_);
}

ModeVector PlainImmTracker::mode_probabilities() const {
  return std::visit([](const auto& imm) { return imm.mode_probabilities(); }, imm_);
}

}  // namespace imm
