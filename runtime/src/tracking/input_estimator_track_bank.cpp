// SPDX-License-Identifier: Apache-2.0
// The input-estimator bank: axis filters as lanes, blocks of kBlock lanes stepped in vector loops
// (see the header) by the scan MlpInputEstimatorFilter runs for one (input_estimator_step.hpp).
#include "imm/tracking/input_estimator_track_bank.hpp"

#include <array>
#include <memory>

#include "axis_lane_bank.hpp"
#include "bank_checks.hpp"
#include "filters/input_estimator_step.hpp"
#include "imm/math/lane_math.hpp"

namespace imm {
namespace {

namespace step = input_estimator;

// One scan of one block's W lanes, a track's two lanes failing as one.
template <int W>
[[gnu::flatten]] IMM_VECTOR_CLONES void step_block(const step::Constants& b, double* state,
                                                   std::ptrdiff_t stride, const double* z,
                                                   const double* stepped, double* code,
                                                   double* work) {
  step::scan<W, true>(b, state, stride, z, stepped, code, work, nullptr);
}

}  // namespace

// The scan's constants, made once per bank.
struct InputEstimatorTrackBank::Constants {
  step::Constants b;
};

InputEstimatorTrackBank::InputEstimatorTrackBank(const MlpInputEstimatorModel& model,
                                                 std::size_t capacity, bool wide_blocks)
    : wide_blocks_(wide_blocks) {
  // The one-track filter's checks, with its wording.
  const MlpInputEstimatorFilter check(model, model.settings);
  (void)check;
  allocate(capacity, 2, kBlock, step::kSlots);
  constants_ = std::make_shared<const Constants>(Constants{step::Constants(model)});
  scratch_.assign((3 + 2 * static_cast<std::size_t>(constants_->b.widest)) * kBlock, 0.0);
}

void InputEstimatorTrackBank::initialize(std::size_t track, const GaussianState<4>& state) {
  const std::ptrdiff_t t = checked(track);
  for (int axis = 0; axis < 2; ++axis) {
    const std::ptrdiff_t lane = 2 * t + axis;
    step::start([&](int entry) -> double& { return slot(entry)[lane]; },
                bank::axis_entries(state, axis));
  }
  mark_initialized(t);
}

void InputEstimatorTrackBank::step(std::span<const Eigen::Vector2d> plots,
                                   std::span<StepStatus> status) {
  check_step("InputEstimatorTrackBank", plots.size(), status.size());
  double* work = scratch_.data() + std::ptrdiff_t{3} * kBlock;
  bank::step_blocks<kBlock>(
      plots, status, wide_blocks_, scratch_.data(),
      [&](auto width, std::size_t first, const double* z, const double* stepped, double* code) {
        step_block<decltype(width)::value>(constants_->b, slot(0) + first, stride(), z, stepped,
                                           code, work);
      });
}

GaussianState<4> InputEstimatorTrackBank::estimate(std::size_t track) const {
  return bank::two_axis_estimate(
      checked(track), [&](int e, std::ptrdiff_t lane) { return slot(step::kPrimary + e)[lane]; });
}

Eigen::Vector2d InputEstimatorTrackBank::acceleration(std::size_t track) const {
  const std::ptrdiff_t t = checked(track);
  return {slot(step::kInput)[2 * t], slot(step::kInput)[2 * t + 1]};
}

ModeVector InputEstimatorTrackBank::mode_probabilities(std::size_t track) const {
  (void)checked(track);
  return ModeVector::Ones(2);
}

}  // namespace imm
