// SPDX-License-Identifier: Apache-2.0
// The input-estimator bank: axis filters as lanes, blocks of kBlock lanes stepped in vector loops
// (see the header) by the scan MlpInputEstimatorFilter runs for one (input_estimator_step.hpp).
#include "imm/tracking/input_estimator_track_bank.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>

#include "axis_lane_bank.hpp"
#include "bank_checks.hpp"
#include "filters/input_estimator_step.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/estimation/kalman_filter.hpp"
#include "imm/filters/axis_filter.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/tracking/track_filter.hpp"
#include "initial_state_check.hpp"

namespace imm {
namespace {

namespace step = input_estimator;

// One scan of one block's W lanes, a track's two lanes failing as one; the lanes' ν and S into
// `report` where it is not null.
template <int W>
[[gnu::flatten]] IMM_VECTOR_CLONES void step_block(const step::Constants& b, double* state,
                                                   std::ptrdiff_t stride, const double* z,
                                                   const double* stepped, double* code,
                                                   double* work, step::ScanReport<W>* report) {
  step::scan<W, true>(b, state, stride, z, stepped, code, work, report);
}

// The gating matrix's tracks in chunks: per axis ẑ, S and log S of each track's prediction, and
// whether it cannot be scored (1) or can (0).
constexpr int kGatingChunk = 256;
struct GatingChunk {
  alignas(64) double z_hat[2][kGatingChunk];
  alignas(64) double variance[2][kGatingChunk];
  alignas(64) double log_variance[2][kGatingChunk];
  alignas(64) double unscored[kGatingChunk];
  alignas(64) double gate[kGatingChunk];  // the track's gate
};

// One usable plot (x, y) against the first n tracks of a chunk, into column[0 … n): the axes'
// ν²/S and log N(ν; 0, S) (axis_log_density's arithmetic, the one-track filter's bits), −∞ past
// the track's gate, NaN for a track that cannot be scored. One loop over the tracks without
// branches.
[[gnu::flatten]] IMM_VECTOR_CLONES void score_chunk(const GatingChunk& c, int n, double x, double y,
                                                    double* column) {
  for (int i = 0; i < n; ++i) {
    const double gate = c.gate[i];
    const double nu_x = x - c.z_hat[0][i], nu_y = y - c.z_hat[1][i];
    const double d_x = nu_x * nu_x / c.variance[0][i], d_y = nu_y * nu_y / c.variance[1][i];
    const double log_likelihood = axis_log_density_of(d_x, c.log_variance[0][i]) +
                                  axis_log_density_of(d_y, c.log_variance[1][i]);
    const double gated =
        pick(d_x + d_y > gate, -std::numeric_limits<double>::infinity(), log_likelihood);
    column[i] = pick(c.unscored[i] != 0.0, std::numeric_limits<double>::quiet_NaN(), gated);
  }
}

}  // namespace

// The scan's constants, made once per bank.
struct InputEstimatorTrackBank::Constants {
  step::Constants b;
};

InputEstimatorTrackBank::InputEstimatorTrackBank(const MlpInputEstimatorModel& model,
                                                 std::size_t capacity, bool wide_blocks)
    : LaneStorage("InputEstimatorTrackBank"), wide_blocks_(wide_blocks) {
  // The one-track filter's checks, with its wording.
  const MlpInputEstimatorFilter check(model, model.settings);
  (void)check;
  allocate(capacity, 2, kBlock, step::kSlots);
  constants_ = std::make_shared<const Constants>(Constants{step::Constants(model)});
  scratch_.assign((3 + 2 * static_cast<std::size_t>(constants_->b.widest)) * kBlock, 0.0);
}

void InputEstimatorTrackBank::initialize(std::size_t track, const GaussianState<4>& state) {
  const std::ptrdiff_t t = checked(track);
  detail::check_initial_state(state);
  for (int axis = 0; axis < 2; ++axis) {
    const std::ptrdiff_t lane = 2 * t + axis;
    step::start([&](int entry) -> double& { return slot(entry)[lane]; },
                bank::axis_entries(state, axis));
  }
  mark_initialized(t);
}

void InputEstimatorTrackBank::step_lanes(const LaneStep& call) {
  double* work = scratch_.data() + std::ptrdiff_t{3} * kBlock;
  bank::step_blocks<kBlock>(
      call.plots, call.status, wide_blocks_, scratch_.data(),
      [&](auto width, std::size_t first, const double* z, const double* stepped, double* code) {
        constexpr int W = decltype(width)::value;
        if (call.nis == nullptr) {
          step_block<W>(constants_->b, slot(0) + first, stride(), z, stepped, code, work, nullptr);
          return;
        }
        step::ScanReport<W> report;  // NOLINT(cppcoreguidelines-pro-type-member-init): written
        step_block<W>(constants_->b, slot(0) + first, stride(), z, stepped, code, work, &report);
        // The one-track filter's innovation (TwoAxisFilter: diag(S_x, S_y)) and last_step_nis's
        // arithmetic on it.
        for (int l = 0; l < W && first / 2 + l / 2 < call.plots.size(); l += 2) {
          const std::size_t track = first / 2 + static_cast<std::size_t>(l / 2);
          call.nis[track] =
              code[l] == step::kOk
                  ? bank::diagonal_nis(report.nu[l], report.nu[l + 1], report.s[l], report.s[l + 1])
                  : std::numeric_limits<double>::quiet_NaN();
        }
      });
}

void InputEstimatorTrackBank::score_lanes(const LaneScore& call) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  const Matrix<1, 2> H{{1.0, 0.0}};
  const SquareMatrix<1> R = SquareMatrix<1>::Constant(constants_->b.cv.R);
  for (Eigen::Index first = 0; first < call.out.rows(); first += kGatingChunk) {
    const int n = static_cast<int>(std::min<Eigen::Index>(kGatingChunk, call.out.rows() - first));
    // The first n entries of each row are written before they are read.
    GatingChunk chunk;  // NOLINT(cppcoreguidelines-pro-type-member-init)
    for (int i = 0; i < n; ++i) {
      // Per axis ẑ and S of the held prediction (predict_plot, as score_candidate forms them for
      // the one-track filter), and log S for every candidate's density.
      bool scored = true;
      for (int axis = 0; axis < 2; ++axis) {
        const std::ptrdiff_t lane = 2 * (first + i) + axis;
        const GaussianState<2> held =
            step::held_prediction(constants_->b, [&](int entry) { return slot(entry)[lane]; });
        Vector<1> mean = Vector<1>::Zero();  // an axis not scored leaves them so
        SquareMatrix<1> S = SquareMatrix<1>::Zero();
        scored = scored && predict_plot(held, H, R, mean, S) && S(0, 0) > 0.0;
        chunk.z_hat[axis][i] = mean(0);
        chunk.variance[axis][i] = S(0, 0);
        chunk.log_variance[axis][i] = std::log(S(0, 0));
      }
      chunk.unscored[i] = scored ? 0.0 : 1.0;
      chunk.gate[i] = call.gate_of(static_cast<std::size_t>(first + i));
    }
    for (std::size_t q = 0; q < call.plots.size(); ++q) {
      double* column = &call.out(first, static_cast<Eigen::Index>(q));
      if (!limits::usable_measurement(call.plots[q])) {
        std::fill(column, column + n, kNaN);
      } else {
        score_chunk(chunk, n, call.plots[q](0), call.plots[q](1), column);
      }
    }
  }
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
