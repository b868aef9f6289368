// SPDX-License-Identifier: Apache-2.0
#include "imm/tracking/tracker.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include "imm/core/enum_names.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm/models/measurement/polar_measurement.hpp"

namespace imm {
namespace {

// The plain IMM (either mixing dimension) behind the TrackFilter interface.
class PlainImmFilter final : public TrackFilter {
 public:
  explicit PlainImmFilter(const PlainImmSpec& spec) : spec_(spec), imm_(build_plain_imm(spec)) {}

  [[nodiscard]] int state_dimension() const override { return spec_.mixing_dimension(); }
  [[nodiscard]] int mode_count() const override { return static_cast<int>(spec_.modes.size()); }
  [[nodiscard]] std::string mode_name(int j) const override {
    return spec_.modes[static_cast<std::size_t>(j)].name;
  }

  void initialize(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) override {
    require_initial_state(mean, covariance, state_dimension());
    std::visit(
        [&](auto& imm) {
          constexpr int kNx = std::decay_t<decltype(imm)>::kDim;
          GaussianState<kNx> state;
          state.mean = mean;
          state.covariance = covariance;
          imm.initialize(state);
        },
        imm_);
  }

  StepStatus step(const Eigen::Vector2d& z) override {
    return std::visit([&](auto& imm) { return imm.step(z); }, imm_);
  }

  StepStatus predict_only() override {
    return std::visit([](auto& imm) { return imm.predict_only(); }, imm_);
  }

  void state(Eigen::Ref<Eigen::VectorXd> mean,
             Eigen::Ref<Eigen::VectorXd> variance) const override {
    std::visit(
        [&](const auto& imm) {
          mean = imm.estimate().mean;
          variance = imm.estimate().covariance.diagonal();
        },
        imm_);
  }

  void covariance(Eigen::Ref<Eigen::MatrixXd> covariance) const override {
    std::visit([&](const auto& imm) { covariance = imm.estimate().covariance; }, imm_);
  }

  [[nodiscard]] ModeVector mode_probabilities() const override {
    return std::visit([](const auto& imm) { return imm.mode_probabilities(); }, imm_);
  }

  bool innovation(Eigen::Vector2d& nu, Eigen::Matrix2d& S) const override {
    return std::visit([&](const auto& imm) { return imm.innovation(nu, S); }, imm_);
  }

  [[nodiscard]] double log_predictive_likelihood() const override {
    return std::visit([](const auto& imm) { return imm.log_predictive_likelihood(); }, imm_);
  }

  [[nodiscard]] bool has_split_cycle() const override { return true; }
  [[nodiscard]] bool predicts_before_the_plot() const override {
    return std::visit([](const auto& imm) { return imm.predicts_before_the_plot(); }, imm_);
  }
  StepStatus predict() override {
    return std::visit([](auto& imm) { return imm.predict(); }, imm_);
  }
  [[nodiscard]] double candidate_log_likelihood(const Eigen::Vector2d& z) const override {
    return std::visit([&](const auto& imm) { return imm.candidate_log_likelihood(z); }, imm_);
  }
  [[nodiscard]] double candidate_distance(const Eigen::Vector2d& z) const override {
    return std::visit([&](const auto& imm) { return imm.candidate_distance(z); }, imm_);
  }
  bool predicted_plot(Eigen::Vector2d& z_hat, Eigen::Matrix2d& S) const override {
    return std::visit([&](const auto& imm) { return imm.predicted_plot(z_hat, S); }, imm_);
  }
  StepStatus update(const Eigen::Vector2d& z) override {
    return std::visit([&](auto& imm) { return imm.update(z); }, imm_);
  }
  [[nodiscard]] bool takes_any_interval() const override {
    return std::visit([](const auto& imm) { return imm.takes_any_interval(); }, imm_);
  }
  bool set_interval(double interval) override {
    const double periods = interval / spec_.sample_period;
    return std::visit([&](auto& imm) { return imm.set_interval(interval, periods); }, imm_);
  }
  StepStatus miss() override {
    return std::visit([](auto& imm) { return imm.miss(); }, imm_);
  }

 private:
  PlainImmSpec spec_;
  PlainImm imm_;
};

}  // namespace

namespace {
// later − earlier, for later > earlier: exact in unsigned arithmetic, where the signed difference
// overflows for scans more than 2⁶³ apart (a recording's first scan near −2⁶³, say).
std::uint64_t scans_between(std::int64_t earlier, std::int64_t later) {
  return static_cast<std::uint64_t>(later) - static_cast<std::uint64_t>(earlier);
}

// Whether `later` is more than `max_gap` (≥ 1) scans after `earlier`.
bool more_than(std::int64_t max_gap, std::int64_t earlier, std::int64_t later) {
  return scans_between(earlier, later) > static_cast<std::uint64_t>(max_gap);
}

constexpr std::array kTrackEventNames{EnumName<TrackEvent>{TrackEvent::kWaiting, "waiting"},
                                      EnumName<TrackEvent>{TrackEvent::kInitialized, "initialized"},
                                      EnumName<TrackEvent>{TrackEvent::kUpdated, "updated"},
                                      EnumName<TrackEvent>{TrackEvent::kRejected, "rejected"}};
}  // namespace

std::string_view to_string(TrackEvent event) { return name_of(kTrackEventNames, event); }

std::unique_ptr<TrackFilter> make_plain_imm_filter(const PlainImmSpec& spec) {
  return std::make_unique<PlainImmFilter>(spec);
}

TrackOptions PlainImmSpec::track_options(std::int64_t max_gap) const {
  TrackOptions options;
  options.sample_period = sample_period;
  options.measurement_kind = measurement.kind;
  options.measurement_covariance = measurement.covariance;
  options.initialization = initialization;
  options.max_gap = max_gap;
  return options;
}

std::optional<double> normalized_innovation_squared(const Eigen::Vector2d& nu,
                                                    const Eigen::Matrix2d& S) {
  const Eigen::LLT<Eigen::Matrix2d> llt(S);
  if (llt.info() != Eigen::Success) return std::nullopt;
  return nu.dot(llt.solve(nu));
}

std::optional<double> last_step_nis(const TrackFilter& filter) {
  Eigen::Vector2d nu;
  Eigen::Matrix2d S;
  if (!filter.innovation(nu, S)) return std::nullopt;
  return normalized_innovation_squared(nu, S);
}

namespace {
[[noreturn]] void no_split_cycle(const char* call) {
  throw std::logic_error(std::string("TrackFilter::") + call +
                         ": this filter does not split its cycle (has_split_cycle() is false); "
                         "use step() and predict_only()");
}
}  // namespace

StepStatus TrackFilter::predict() { no_split_cycle("predict"); }

double TrackFilter::candidate_log_likelihood(const Eigen::Vector2d& /*z*/) const {
  return std::numeric_limits<double>::quiet_NaN();
}

double TrackFilter::candidate_distance(const Eigen::Vector2d& /*z*/) const {
  return std::numeric_limits<double>::quiet_NaN();
}

bool TrackFilter::predicted_plot(Eigen::Vector2d& /*z_hat*/, Eigen::Matrix2d& /*S*/) const {
  return false;
}

StepStatus TrackFilter::update(const Eigen::Vector2d& /*z*/) { no_split_cycle("update"); }

StepStatus TrackFilter::miss() { no_split_cycle("miss"); }

double TrackFilter::log_predictive_likelihood() const {
  Eigen::Vector2d nu;
  Eigen::Matrix2d S;
  if (!innovation(nu, S)) return std::numeric_limits<double>::quiet_NaN();
  return log_normal_density(nu, S);
}

Tracker::Tracker(std::unique_ptr<TrackFilter> filter, TrackOptions options)
    : filter_(std::move(filter)), options_(std::move(options)), envelope_(options_.envelope) {
  if (!filter_) throw InvalidParameter("filter", "must not be null");
  // A gap is predicted through scan by scan: a bound keeps one plot's cost bounded (a million
  // predictions is about a second), whatever scans a hostile input names.
  constexpr std::int64_t kLongestMaxGap = 1'000'000;
  if (options_.max_gap < 1 || options_.max_gap > kLongestMaxGap) {
    throw InvalidParameter("max_gap", "must be in [1, " + std::to_string(kLongestMaxGap) +
                                          "] scans, got " + std::to_string(options_.max_gap));
  }
  limits::require_sample_period(options_.sample_period, "sample_period");
  const int n = filter_->state_dimension();
  if (options_.initialization.method == InitializationMethod::kExplicit &&
      (options_.initialization.state.size() != n ||
       options_.initialization.covariance.rows() != n ||
       options_.initialization.covariance.cols() != n)) {
    throw InvalidParameter("initialization.state",
                           "must match the filter's " + std::to_string(n) + " states");
  }
}

namespace {

// Two-point initialization: position from the second plot, velocity from the difference;
// cov(p) = R₂, cov(v) = (R₁ + R₂)/Δt², cov(p, v) = R₂/Δt (Bar-Shalom, Li & Kirubarajan §5.5.3).
// Nothing where that start is not finite, where the plots are closer in time than the shortest
// interval a filter takes (limits::kSamplePeriod's 1 µs) or where the velocity is beyond
// limits::kSpeed. Plots 1e-12 s apart once started a track at 10¹³ m/s whose velocity variance
// (2 R / Δt², 10²⁴ times the position's) left the second update no longer finite, and every plot
// was refused until the track was lost; at Δt ≥ 1 µs the ratio is at most 2·10¹² s⁻².
std::optional<TrackStart> start_from(const TrackOptions& options, int n, double dt,
                                     const Eigen::Vector2d& p1, const Eigen::Matrix2d& r1,
                                     const Eigen::Vector2d& p2, const Eigen::Matrix2d& r2) {
  // [x, vx, (ax), y, vy, (ay)], then ω when the state has an odd dimension (a CT mode's).
  const int per_axis = n / 2;
  TrackStart start{Eigen::VectorXd::Zero(n), Eigen::MatrixXd::Zero(n, n)};
  for (int axis = 0; axis < 2; ++axis) {
    const int p = axis * per_axis;
    start.mean(p) = p2(axis);
    start.mean(p + 1) = (p2(axis) - p1(axis)) / dt;
    for (int other = 0; other < 2; ++other) {
      const int q = other * per_axis;
      start.covariance(p, q) = r2(axis, other);
      start.covariance(p, q + 1) = r2(axis, other) / dt;
      start.covariance(p + 1, q) = r2(axis, other) / dt;
      start.covariance(p + 1, q + 1) = (r1(axis, other) + r2(axis, other)) / (dt * dt);
    }
    if (per_axis == 3)
      start.covariance(p + 2, p + 2) = options.initialization.acceleration_variance;
  }
  if (n % 2 == 1) start.covariance(n - 1, n - 1) = options.initialization.turn_rate_variance;
  if (!(dt >= limits::kSamplePeriod.min) || !start.mean.allFinite() ||
      !start.covariance.allFinite()) {
    return std::nullopt;
  }
  for (int axis = 0; axis < 2; ++axis) {
    if (std::abs(start.mean(axis * per_axis + 1)) > limits::kSpeed.max) return std::nullopt;
  }
  return start;
}

CartesianPlot cartesian(const TrackOptions& options, const Eigen::Vector2d& z) {
  if (options.measurement_kind == MeasurementKind::kCartesian) {
    return {z, options.measurement_covariance};
  }
  return polar_to_cartesian(z, options.measurement_covariance);
}

}  // namespace

std::optional<TrackStart> two_point_start(const TrackOptions& options, int state_dimension,
                                          std::int64_t first_scan, const Eigen::Vector2d& first,
                                          std::int64_t second_scan, const Eigen::Vector2d& second) {
  if (second_scan <= first_scan || state_dimension < 4) return std::nullopt;
  const CartesianPlot a = cartesian(options, first), b = cartesian(options, second);
  if (!a.position.allFinite() || !b.position.allFinite()) return std::nullopt;
  const double dt =
      static_cast<double>(scans_between(first_scan, second_scan)) * options.sample_period;
  return start_from(options, state_dimension, dt, a.position, a.covariance, b.position,
                    b.covariance);
}

Tracker::Plot Tracker::cartesian_plot(std::int64_t scan, double time,
                                      const Eigen::Vector2d& z) const {
  const CartesianPlot converted = cartesian(options_, z);
  return {scan, time, converted.position, converted.covariance};
}

bool Tracker::start_track(const Plot& first, const Plot& second) {
  const int n = filter_->state_dimension();
  const double dt =
      clock_ == Clock::kTimes
          ? second.time - first.time
          : static_cast<double>(scans_between(first.scan, second.scan)) * options_.sample_period;
  const std::optional<TrackStart> start = start_from(
      options_, n, dt, first.position, first.covariance, second.position, second.covariance);
  if (!start) return false;
  filter_->initialize(start->mean, start->covariance);
  return true;
}

TrackStepResult Tracker::reject(StepStatus status, std::string_view reason) const {
  TrackStepResult result;
  result.event = TrackEvent::kRejected;
  result.status = status;
  result.reason = reason;
  return with_envelope(result);
}

TrackStepResult Tracker::with_envelope(TrackStepResult result) const {
  result.outside_envelope = envelope_.outside();
  result.envelope_nis = envelope_.mean();
  return result;
}

std::optional<TrackStepResult> Tracker::unusable(const Eigen::Vector2d& z) const {
  if (!limits::usable_measurement(z)) {
    return reject(StepStatus::kInvalidMeasurement,
                  "measurement is NaN, infinite or beyond the physical range (|z| > 1e9)");
  }
  return std::nullopt;
}

TrackStepResult Tracker::start_at(std::int64_t scan, double time, const Eigen::Vector2d& z) {
  envelope_.reset();  // a new track, a new window
  TrackStepResult result;
  if (options_.initialization.method == InitializationMethod::kExplicit) {
    filter_->initialize(options_.initialization.state, options_.initialization.covariance);
    const StepStatus status = filter_->step(z);
    if (status != StepStatus::kOk) return reject(status, to_string(status));
    initialized_ = true;
    last_scan_ = scan, last_time_ = time;
    result.event = TrackEvent::kInitialized;
    return with_envelope(result);
  }
  const Plot plot = cartesian_plot(scan, time, z);
  if (!plot.position.allFinite()) {
    return reject(StepStatus::kInvalidMeasurement, "measurement is not convertible to a position");
  }
  // No first plot yet, one too long ago, or one too close in time for a start: this plot
  // is the first.
  const bool first = !first_plot_ || (clock_ == Clock::kTimes
                                          ? time - first_plot_->time > longest_gap()
                                          : more_than(options_.max_gap, first_plot_->scan, scan));
  if (first || !start_track(*first_plot_, plot)) {
    first_plot_ = plot;
    last_scan_ = scan, last_time_ = time;
    result.event = TrackEvent::kWaiting;
    return with_envelope(result);
  }
  first_plot_.reset();
  initialized_ = true;
  last_scan_ = scan, last_time_ = time;
  result.event = TrackEvent::kInitialized;
  return with_envelope(result);
}

TrackStepResult Tracker::process(std::int64_t scan, const Eigen::Vector2d& z) {
  if (clock_ == Clock::kTimes) {
    return reject(StepStatus::kInvalidMeasurement, "this tracker is fed times (process_at)");
  }
  clock_ = Clock::kScans;
  return process_scan(scan, 0.0, z);
}

TrackStepResult Tracker::process_scan(std::int64_t scan, double time, const Eigen::Vector2d& z) {
  if (last_scan_ && scan <= *last_scan_) {
    return reject(StepStatus::kUnsupportedInterval, "scan index does not increase");
  }
  if (auto bad = unusable(z)) return *bad;

  if (initialized_ && more_than(options_.max_gap, *last_scan_, scan)) {
    initialized_ = false;  // track lost: start again from this plot
    first_plot_.reset();
  }
  if (!initialized_) return start_at(scan, time, z);

  // Predict through the skipped scans (fewer than max_gap), then update. If the update fails, the
  // predictions stay: the track then stands at the scan before this plot.
  TrackStepResult result;
  const std::int64_t gap = scan - *last_scan_ - 1;
  for (std::int64_t i = 0; i < gap; ++i) {
    const StepStatus status = filter_->predict_only();
    if (status != StepStatus::kOk) {
      last_scan_ = *last_scan_ + i;
      TrackStepResult failed = reject(status, to_string(status));
      failed.predicted_scans = i;
      return failed;
    }
    ++result.predicted_scans;
  }
  const StepStatus status = filter_->step(z);
  last_scan_ = scan - (status == StepStatus::kOk ? 0 : 1);
  if (status != StepStatus::kOk) {
    TrackStepResult failed = reject(status, to_string(status));
    failed.predicted_scans = result.predicted_scans;
    return failed;
  }
  result.event = TrackEvent::kUpdated;
  // The envelope test: this update's NIS into the window (fixed storage, no allocation).
  if (const auto nis = last_step_nis(*filter_)) (void)envelope_.add(*nis);
  return with_envelope(result);
}

TrackStepResult Tracker::process_at(double time, const Eigen::Vector2d& z) {
  if (clock_ == Clock::kScans) {
    return reject(StepStatus::kInvalidMeasurement, "this tracker is fed scans (process)");
  }
  if (!std::isfinite(time) || std::abs(time) > 1e12) {
    return reject(StepStatus::kInvalidMeasurement, "time is NaN, infinite or beyond ±1e12 s");
  }
  if (last_time_ && !(time > *last_time_)) {
    return reject(StepStatus::kUnsupportedInterval, "time does not increase");
  }
  clock_ = Clock::kTimes;
  if (filter_->takes_any_interval()) return process_interval(time, z);
  // A filter of one sample period: the plot's scan counted from the last one.
  const double period = options_.sample_period;
  std::int64_t scan = 0;
  if (last_time_) {
    const std::int64_t periods = whole_periods(time - *last_time_, period);
    if (periods == 0) {
      return reject(StepStatus::kUnsupportedInterval,
                    "time is not a whole number of the model's sample periods after the last plot");
    }
    scan = *last_scan_ + periods;
  }
  const std::int64_t scan_before = last_scan_.value_or(0);
  const double time_before = last_time_.value_or(time);
  TrackStepResult result = process_scan(scan, time, z);
  // The time the track stands at: the plot's, or that of the last period predicted through.
  if (result.event != TrackEvent::kRejected) {
    last_time_ = time;
  } else if (last_scan_) {
    last_time_ = time_before + static_cast<double>(*last_scan_ - scan_before) * period;
  }
  return result;
}

TrackStepResult Tracker::process_interval(double time, const Eigen::Vector2d& z) {
  if (auto bad = unusable(z)) return *bad;
  if (initialized_ && time - *last_time_ > longest_gap()) {
    initialized_ = false;  // track lost: start again from this plot
    first_plot_.reset();
  }
  if (!initialized_) return start_at(0, time, z);
  TrackStepResult result;
  const StepStatus status = step_over(*filter_, options_.sample_period, time - *last_time_, z);
  if (status != StepStatus::kOk) return reject(status, to_string(status));
  last_time_ = time;
  result.event = TrackEvent::kUpdated;
  if (const auto nis = last_step_nis(*filter_)) (void)envelope_.add(*nis);
  return with_envelope(result);
}

// Eigen::Ref is a writable view and is passed by value by design.
void Tracker::state(
    Eigen::Ref<Eigen::VectorXd> mean,              // NOLINT(performance-unnecessary-value-param)
    Eigen::Ref<Eigen::VectorXd> variance) const {  // NOLINT(performance-unnecessary-value-param)
  if (!initialized_) throw std::logic_error("Tracker::state before initialization");
  filter_->state(mean, variance);
}

void Tracker::covariance(
    Eigen::Ref<Eigen::MatrixXd> covariance) const {  // NOLINT(performance-unnecessary-value-param)
  if (!initialized_) throw std::logic_error("Tracker::covariance before initialization");
  filter_->covariance(covariance);
}

}  // namespace imm
