// SPDX-License-Identifier: Apache-2.0
#include "imm/tracking/track_bank.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

#include "bank_checks.hpp"
#include "filters/mode_field.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/estimation/imm_algebra.hpp"
#include "imm/estimation/mode_transitions.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "initial_state_check.hpp"
#include "track_bank_kernel.hpp"

namespace imm {
namespace {

using namespace bank;  // NOLINT(google-build-using-namespace): the bank's own kernel

}  // namespace

TrackBank::TrackBank(const PlainImmSpec& spec, std::size_t capacity) : TrackBankCalls("TrackBank") {
  spec.validate();
  for (std::size_t i = 0; i < spec.modes.size(); ++i) {
    if (spec.modes[i].motion != MotionKind::kConstantVelocity) {
      throw InvalidParameter(detail::mode_field(i, "motion"),
                             "the track bank runs constant-velocity modes only, got '" +
                                 std::string(to_string(spec.modes[i].motion)) +
                                 "' (PlainImmTrackBank runs every plain IMM)");
    }
    if (spec.modes[i].noise_schedule) {
      throw InvalidParameter(detail::mode_field(i, "noise_schedule"),
                             "the track bank runs fixed process noise only (PlainImmTrackBank "
                             "runs every plain IMM)");
    }
  }
  if (spec.measurement.kind != MeasurementKind::kCartesian) {
    throw InvalidParameter("measurement.kind",
                           "the track bank needs a Cartesian measurement (PlainImmTrackBank runs "
                           "every plain IMM)");
  }
  hold_tracks(capacity);
  modes_ = static_cast<int>(spec.modes.size());
  const auto tiles = (capacity + kBlock - 1) / kBlock;
  tile_ = static_cast<std::ptrdiff_t>(modes_ * kModeSlots + kEntries) * kBlock;
  prediction_tile_ = static_cast<std::ptrdiff_t>(modes_ * kPlotSlots + kCollapsedSlots) * kBlock;
  sample_period_ = spec.sample_period;
  per_period_ = spec.transition;
  const auto n = static_cast<std::size_t>(modes_);
  transition_.resize(n * n);
  log_transition_.resize(n * n);
  for (int i = 0; i < modes_; ++i) {
    initial_log_mu_.push_back(safe_log(spec.initial_probabilities(i)));
  }
  for (const ModeSpec& mode : spec.modes) {
    motion_.push_back({mode.process_noise, mode.noise_form});
  }
  noise_.resize(n * static_cast<std::size_t>(kTriangle));
  remake(spec.sample_period, spec.transition);
  r00_ = spec.measurement.covariance(0, 0);
  r01_ = spec.measurement.covariance(0, 1);
  r11_ = spec.measurement.covariance(1, 1);
  state_.assign(tiles * static_cast<std::size_t>(tile_), 0.0);
  prediction_.assign(tiles * static_cast<std::size_t>(prediction_tile_), 0.0);
  innovations_.assign(static_cast<std::size_t>(bank::kInnovationDoubles), 0.0);
}

void TrackBank::initialize(std::size_t track, const GaussianState<kDim>& state) {
  const std::ptrdiff_t t = checked(track);
  detail::check_initial_state(state);
  double shift = -std::numeric_limits<double>::infinity();
  for (double v : initial_log_mu_) shift = std::max(shift, v);
  for (int j = 0; j < modes_; ++j) {
    for (int a = 0; a < kDim; ++a) {
      at(mode_slot(j, kMean + a), t) = state.mean(a);
      for (int c = a; c < kDim; ++c) at(mode_slot(j, kCov + sym(a, c)), t) = state.covariance(a, c);
    }
    const double log_mu = initial_log_mu_[static_cast<std::size_t>(j)];
    at(mode_slot(j, kLogMu), t) = log_mu;
    at(mode_slot(j, kScaledMu), t) = std::exp(log_mu - shift);
  }
  // The combination with μ₀, as ImmEstimator::initialize combines (imm_algebra.hpp's collapse):
  // every mode starts at `state`, as stored (the covariance's upper triangle).
  algebra::collapse<kDim, double>(
      modes_, [this](int j) { return std::exp(initial_log_mu_[static_cast<std::size_t>(j)]); },
      [&state](int /*j*/, int a) { return state.mean(a); },
      [&state](int /*j*/, int a, int c) { return state.covariance(a, c); },
      [&](int a) -> double& { return at(combined_slot(kMean + a), t); },
      [&](int a, int c) -> double& { return at(combined_slot(kCov + sym(a, c)), t); });
  mark_initialized(t);
}

void TrackBank::step_lanes(const LaneStep& call) {
  for (std::size_t first = 0; first < call.plots.size(); first += kBlock) {
    const int lanes = static_cast<int>(std::min<std::size_t>(kBlock, call.plots.size() - first));
    run_block(first, lanes, call.plots.data() + first, call.status.data() + first,
              call.nis == nullptr ? nullptr : call.nis + first);
  }
}

void TrackBank::score_lanes(const LaneScore& call) {
  const auto tracks = static_cast<std::size_t>(call.out.rows());
  Scoring scoring;
  scoring.modes = modes_;
  scoring.stride = kBlock;
  scoring.plots = call.plots.data();
  scoring.plot_count = static_cast<int>(call.plots.size());
  scoring.gate = call.gate;
  scoring.out_stride = call.out.outerStride();
  for (std::size_t first = 0; first < tracks; first += kBlock) {
    const int lanes = static_cast<int>(std::min<std::size_t>(kBlock, tracks - first));
    run_block(first, lanes, nullptr, nullptr, nullptr, true);
    scoring.tracks = lanes;
    scoring.prediction = prediction_.data() + first / kBlock * prediction_tile_;
    scoring.out = call.out.data() + first;
    scoring.gate_scale = call.gate_scale == nullptr ? nullptr : call.gate_scale + first;
    score_plots(scoring);
  }
}

void TrackBank::remake(double interval, const ModeMatrix& transition) {
  period_ = interval;
  const auto n = static_cast<std::size_t>(modes_);
  for (int i = 0; i < modes_; ++i) {
    for (int j = 0; j < modes_; ++j) {
      const std::size_t at = static_cast<std::size_t>(i) * n + static_cast<std::size_t>(j);
      transition_[at] = transition(i, j);
      log_transition_[at] = safe_log(transition(i, j));
    }
  }
  std::size_t at = 0;
  for (const MotionParameters& mode : motion_) {
    const auto cv = constant_velocity<2>(interval, mode.process_noise, mode.form);
    for (int a = 0; a < kDim; ++a)
      for (int c = a; c < kDim; ++c) noise_[at++] = cv.process_noise(a, c);
  }
}

bool TrackBank::set_interval(double interval) {
  if (!limits::kSamplePeriod.contains(interval)) return false;
  if (interval == period_) return true;
  ModeMatrix transition;
  transition_over(per_period_, interval / sample_period_, transition);
  remake(interval, transition);
  return true;
}

void TrackBank::run_block(std::size_t first, int lanes, const Eigen::Vector2d* plots,
                          StepStatus* status, double* nis, bool predict) {
  Block block;
  block.modes = modes_;
  block.lanes = lanes;
  block.period = period_;
  block.transition = transition_.data();
  block.log_transition = log_transition_.data();
  block.noise = noise_.data();
  block.r00 = r00_;
  block.r01 = r01_;
  block.r11 = r11_;
  const auto tile = static_cast<std::ptrdiff_t>(first / kBlock);
  block.state = state_.data() + tile * tile_;
  block.stride = kBlock;
  block.plots = plots;
  block.status = status;
  block.nis = nis;
  block.innovations = innovations_.data();
  if (predict) return predict_plots(block, prediction_.data() + tile * prediction_tile_);
  step_tracks(block);
}

int TrackBank::mode_slot(int j, int entry) const { return imm_mode_slot(j, kEntries, entry); }

int TrackBank::combined_slot(int entry) const { return imm_mode_slot(modes_, kEntries, entry); }

GaussianState<TrackBank::kDim> TrackBank::mode_estimate(std::size_t track, int j) const {
  const std::ptrdiff_t t = checked(track);
  if (j < 0 || j >= modes_) throw std::out_of_range("mode " + std::to_string(j));
  GaussianState<kDim> out;
  for (int a = 0; a < kDim; ++a) {
    out.mean(a) = at(mode_slot(j, kMean + a), t);
    for (int c = 0; c < kDim; ++c) out.covariance(a, c) = at(mode_slot(j, kCov + sym(a, c)), t);
  }
  return out;
}

GaussianState<TrackBank::kDim> TrackBank::estimate(std::size_t track) const {
  const std::ptrdiff_t t = checked(track);
  GaussianState<kDim> out;
  for (int a = 0; a < kDim; ++a) {
    out.mean(a) = at(combined_slot(kMean + a), t);
    for (int c = 0; c < kDim; ++c) out.covariance(a, c) = at(combined_slot(kCov + sym(a, c)), t);
  }
  return out;
}

ModeVector TrackBank::log_mode_probabilities(std::size_t track) const {
  const std::ptrdiff_t t = checked(track);
  ModeVector out(modes_);
  for (int j = 0; j < modes_; ++j) out(j) = at(mode_slot(j, kLogMu), t);
  return out;
}

ModeVector TrackBank::mode_probabilities(std::size_t track) const {
  ModeVector out = log_mode_probabilities(track);
  for (int j = 0; j < modes_; ++j) out(j) = std::exp(out(j));
  return out;
}

}  // namespace imm
