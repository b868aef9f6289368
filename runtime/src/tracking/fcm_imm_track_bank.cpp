// SPDX-License-Identifier: Apache-2.0
// The FCM-IMM's bank: axis filters as lanes, blocks of kBlock lanes (see the header). The IMM
// cycle follows FcmImmAxisFilter's (ImmEstimator::step) in its order of operations; each mode's
// step is fcm_mode_step.hpp's over a pack, the one FcmCompensatedMode::propose runs for a double,
// with the memberships between its halves.
#include "imm/tracking/fcm_imm_track_bank.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "axis_lane_bank.hpp"
#include "bank_checks.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/estimation/cv_axis_lanes.hpp"
#include "imm/filters/fcm_mode_step.hpp"
#include "imm/filters/fuzzy_noise_step.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"

namespace imm {
namespace {

using bank::kNonFinite, bank::kOk, bank::kSingular, bank::kUnderflow;
using lanes::kMaxLevels;
// Slots of mode j at j * mode_slots + entry: the estimate, log μ, the clustering's window ring
// (head, size, whether it has centers, the centers, then the points, oldest at head).
constexpr int kX0 = 0, kX1 = 1, kP00 = 2, kP01 = 3, kP11 = 4, kLogMu = 5, kHead = 6, kSize = 7,
              kHasCenters = 8, kCenters = 9, kRing = 12;

struct BankConstants {
  int modes, mode_slots, window;
  const double* transition;                  // π_ij at i * modes + j
  lanes::FcmModeConstants mode[kMaxLevels];  // each mode's step
  bool constant;
  ClusterVector constant_u[kMaxLevels];
  ClusterVector lower, upper;
  FuzzyCMeansSettings clustering;
  double* window_scratch;  // window doubles, then 3 window memberships
};

// A mode of a block: its prediction (e, S, the value the window takes), the memberships' u_noise,
// the pending clustering.
template <int W>
struct ModeStep {
  lanes::FcmPrediction<LanePackOf<W>> predicted;
  double u1[W];                        // u_noise of the memberships
  double centers[3][W], clustered[W];  // the pending clustering
};

// One IMM cycle of one block's W lanes. `state` points at the block's first lane of slot 0; `z`
// the lanes' plots (NaN: unusable); `stepped` 1 for a lane to step; `code` receives each lane's
// outcome.
template <int W>
[[gnu::flatten]] IMM_VECTOR_CLONES void step_block(const BankConstants& b, double* state,
                                                   std::ptrdiff_t stride, const double* z,
                                                   const double* stepped, double* code) {
  using Lanes = double[W];
  using Pack = LanePackOf<W>;
  const int n = b.modes;
  auto st = [&](int j, int entry) { return state + (j * b.mode_slots + entry) * stride; };

  lanes::AxisModes<W> now;  // NOLINT(cppcoreguidelines-pro-type-member-init)
  for (int i = 0; i < n; ++i) {
    IMM_LANES {
      now.x0[i][l] = st(i, kX0)[l];
      now.x1[i][l] = st(i, kX1)[l];
      now.p00[i][l] = st(i, kP00)[l];
      now.p01[i][l] = st(i, kP01)[l];
      now.p11[i][l] = st(i, kP11)[l];
    }
  }
  // log c_j = log Σ_i p_ij μ̃_i + max log μ, μ̃_i = exp(log μ_i − max log μ)
  // (ImmEstimator::predict_mode_probabilities), and the mixing weights μ_ij = p_ij μ̃_i / c̃_j.
  Lanes shift, scaled[kMaxLevels], predicted[kMaxLevels], log_predicted[kMaxLevels];
  IMM_LANES shift[l] = st(0, kLogMu)[l];
  for (int i = 1; i < n; ++i) {
    const double* log_mu = st(i, kLogMu);
    IMM_LANES shift[l] = pick(log_mu[l] > shift[l], log_mu[l], shift[l]);
  }
  for (int i = 0; i < n; ++i) {
    const double* log_mu = st(i, kLogMu);
    IMM_LANES scaled[i][l] = std::exp(log_mu[l] - shift[l]);
  }
  for (int j = 0; j < n; ++j) {
    IMM_LANES predicted[j][l] = 0.0;
    for (int i = 0; i < n; ++i) {
      const double p = b.transition[i * n + j];
      IMM_LANES predicted[j][l] += p * scaled[i][l];
    }
    IMM_LANES log_predicted[j][l] = std::log(predicted[j][l]) + shift[l];
  }
  // Each mode: its mixed initial condition (eq. 4–6) and fcm_predict.
  ModeStep<W> m[kMaxLevels];  // NOLINT(cppcoreguidelines-pro-type-member-init)
  const Pack plots = lane_load<Pack>(z);
  for (int j = 0; j < n; ++j) {
    Lanes weight[kMaxLevels];
    for (int i = 0; i < n; ++i) {
      const double p = b.transition[i * n + j];
      IMM_LANES weight[i][l] = p * scaled[i][l] / predicted[j][l];
    }
    Lanes m0, m1, c00, c01, c11;
    lanes::mix<W>(n, weight, now, m0, m1, c00, c01, c11);
    m[j].predicted =
        lanes::fcm_predict<Pack>(b.mode[j],
                                 {lane_load<Pack>(m0), lane_load<Pack>(m1), lane_load<Pack>(c00),
                                  lane_load<Pack>(c01), lane_load<Pack>(c11)},
                                 plots);
  }
  // The memberships of every lane's new error in its window (SlidingFuzzyCMeans::propose), one
  // lane and mode at a time; none where the step cannot succeed (an unusable plot or S).
  for (int j = 0; j < n; ++j) {
    ModeStep<W>& s = m[j];
    for (int l = 0; l < W; ++l) {
      s.clustered[l] = 0.0;
      s.u1[l] = 1.0;
      if (b.constant) {
        s.u1[l] = b.constant_u[j](1);
        continue;
      }
      const double x = s.predicted.clustered[l];
      const bool usable = stepped[l] != 0.0 && std::isfinite(x) && s.predicted.usable[l] != 0;
      const int size = static_cast<int>(st(j, kSize)[l]);
      const int kept = std::min(size, b.window - 1);
      if (!usable || kept + 1 < kFcmClusters) continue;
      const int head = static_cast<int>(st(j, kHead)[l]), skip = size - kept;
      double* window = b.window_scratch;
      for (int i = 0; i < kept; ++i) window[i] = st(j, kRing + (head + skip + i) % b.window)[l];
      window[kept] = x;
      const auto points = static_cast<std::size_t>(kept) + 1;
      const ClusterVector previous(st(j, kCenters)[l], st(j, kCenters + 1)[l],
                                   st(j, kCenters + 2)[l]);
      ClusterVector centers;
      int iterations = 0;
      const ClusterVector u = cluster_window(
          std::span<const double>(window, points),
          st(j, kHasCenters)[l] != 0.0 ? &previous : nullptr, b.lower, b.upper, b.clustering,
          std::span<double>(window + b.window, kFcmClusters * points), centers, iterations);
      s.u1[l] = u(1);
      for (int c = 0; c < kFcmClusters; ++c) s.centers[c][l] = centers(c);
      s.clustered[l] = 1.0;
    }
  }
  // Each mode's fcm_update with c = fcm_compensation (λ (1 − u_noise)) and ℓ_j + log c_j.
  Lanes posterior[kMaxLevels], outcome;
  lanes::AxisEstimateOf<Pack> updated[kMaxLevels];
  IMM_LANES outcome[l] = kOk;
  for (int j = 0; j < n; ++j) {
    const Pack compensation = lanes::fcm_compensation(b.mode[j], lane_load<Pack>(m[j].u1));
    const lanes::FcmUpdate<Pack> u =
        lanes::fcm_update<Pack>(b.mode[j], m[j].predicted, compensation);
    updated[j] = u.updated;
    const Pack mode_code = pick(u.factored, pick(u.finite, kOk, kNonFinite), kSingular);
    lane_store(posterior[j], u.log_likelihood + lane_load<Pack>(log_predicted[j]));
    // The first mode that fails decides the status (ImmEstimator stops there).
    const Pack before = lane_load<Pack>(outcome);
    lane_store(outcome, pick(before != kOk, before, mode_code));
  }
  // The posterior in log space (ImmEstimator::finish_cycle).
  Lanes top, sum, log_sum;
  IMM_LANES top[l] = -std::numeric_limits<double>::infinity();
  for (int j = 0; j < n; ++j) {
    IMM_LANES top[l] = pick(posterior[j][l] > top[l], posterior[j][l], top[l]);
  }
  IMM_LANES sum[l] = 0.0;
  for (int j = 0; j < n; ++j) {
    IMM_LANES {
      posterior[j][l] -= top[l];
      sum[l] += std::exp(posterior[j][l]);
    }
  }
  IMM_LANES {
    const bool finite_top = std::abs(top[l]) < std::numeric_limits<double>::infinity();
    outcome[l] = pick((outcome[l] == kOk) & !finite_top, kUnderflow, outcome[l]);
    log_sum[l] = std::log(sum[l]);
  }
  // A track commits when both its lanes (x at an even lane, y after it) succeeded.
  bank::track_codes<W>(outcome, z, code);
  Lanes commit;
  IMM_LANES commit[l] = pick((stepped[l] != 0.0) & (code[l] == kOk), 1.0, 0.0);
  const auto committed = lane_load<Pack>(commit) != 0.0;
  for (int j = 0; j < n; ++j) {
    IMM_LANES posterior[j][l] -= log_sum[l];  // log μ_j
    const lanes::AxisEstimateOf<Pack>& e = updated[j];
    const Pack values[6] = {e.x0, e.x1, e.p00, e.p01, e.p11, lane_load<Pack>(posterior[j])};
    for (int entry = 0; entry < 6; ++entry) {
      double* target = st(j, entry);
      lane_store(target, pick(committed, values[entry], lane_load<Pack>(target)));
    }
  }
  // The committed lanes' windows take the new error, their centers the clustering's
  // (SlidingFuzzyCMeans::commit); the ablation's constant memberships keep no window.
  if (b.constant) return;
  for (int j = 0; j < n; ++j) {
    for (int l = 0; l < W; ++l) {
      if (commit[l] == 0.0) continue;
      const int size = static_cast<int>(st(j, kSize)[l]);
      const int head = static_cast<int>(st(j, kHead)[l]);
      if (size < b.window) {
        st(j, kRing + (head + size) % b.window)[l] = m[j].predicted.clustered[l];
        st(j, kSize)[l] = size + 1;
      } else {
        st(j, kRing + head)[l] = m[j].predicted.clustered[l];
        st(j, kHead)[l] = (head + 1) % b.window;
      }
      if (m[j].clustered[l] != 0.0) {
        for (int c = 0; c < kFcmClusters; ++c) st(j, kCenters + c)[l] = m[j].centers[c][l];
        st(j, kHasCenters)[l] = 1.0;
      }
    }
  }
}

}  // namespace

FcmImmTrackBank::FcmImmTrackBank(const FcmImmSpec& spec, std::size_t capacity) : spec_(spec) {
  spec.validate();
  bank::require_positive_transitions(spec.transition);
  mode_slots_ = kRing + spec.window;
  const int n = spec.mode_count();
  allocate(capacity, 2, kBlock,
           static_cast<std::size_t>(n) * static_cast<std::size_t>(mode_slots_));
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) transition_.push_back(spec.transition(i, j));
  }
  scratch_.assign(
      static_cast<std::size_t>(1 + kFcmClusters) * static_cast<std::size_t>(spec.window), 0.0);
}

void FcmImmTrackBank::initialize(std::size_t track, const GaussianState<4>& state) {
  const std::ptrdiff_t t = checked(track);
  if (!state.all_finite()) throw InvalidParameter("state", "must be finite");
  for (int axis = 0; axis < 2; ++axis) {
    const std::ptrdiff_t lane = 2 * t + axis;
    const std::array<double, 5> values = bank::axis_entries(state, axis);
    for (int j = 0; j < spec_.mode_count(); ++j) {
      auto at = [&](int entry) -> double& { return slot(j * mode_slots_ + entry)[lane]; };
      for (int e = 0; e < 5; ++e) at(kX0 + e) = values[static_cast<std::size_t>(e)];
      at(kLogMu) = safe_log(spec_.initial_probabilities(j));
      at(kHead) = at(kSize) = at(kHasCenters) = 0.0;
      for (int c = 0; c < kFcmClusters; ++c) at(kCenters + c) = 0.0;
    }
  }
  mark_initialized(t);
}

void FcmImmTrackBank::step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status) {
  check_step("FcmImmTrackBank", plots.size(), status.size());
  BankConstants b{};
  b.modes = spec_.mode_count();
  b.mode_slots = mode_slots_;
  b.window = spec_.window;
  b.transition = transition_.data();
  for (int j = 0; j < b.modes; ++j) {
    b.mode[j] = fcm_mode_constants(spec_, j);
    if (spec_.constant_memberships) b.constant_u[j] = spec_.mean_memberships.row(j).transpose();
  }
  b.constant = spec_.constant_memberships;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  b.lower = ClusterVector::Constant(-kInf);
  b.upper = ClusterVector::Constant(kInf);
  if (spec_.scale == MembershipScale::kInnovation) {
    b.upper(0) = -spec_.separation;
    b.lower(1) = b.upper(1) = 0.0;
    b.lower(2) = spec_.separation;
  }
  b.clustering = spec_.clustering;
  b.window_scratch = scratch_.data();
  double lanes[3 * kBlock];  // one block's plots, flags and codes
  bank::step_blocks<kBlock>(
      plots, status, true, lanes,
      [&](auto width, std::size_t first, const double* z, const double* stepped, double* code) {
        step_block<decltype(width)::value>(b, slot(0) + first, stride(), z, stepped, code);
      });
}

GaussianState<4> FcmImmTrackBank::estimate(std::size_t track) const {
  const std::ptrdiff_t t = checked(track);
  const int n = spec_.mode_count();
  // Per axis, the modes moment-matched with μ = exp(log μ) (ImmEstimator::combine).
  std::array<std::array<double, 5>, 2> axes{};
  for (int axis = 0; axis < 2; ++axis) {
    const std::ptrdiff_t lane = 2 * t + axis;
    auto at = [&](int j, int entry) { return slot(j * mode_slots_ + entry)[lane]; };
    double mean0 = 0.0, mean1 = 0.0;
    for (int j = 0; j < n; ++j) {
      const double mu = std::exp(at(j, kLogMu));
      mean0 += mu * at(j, kX0);
      mean1 += mu * at(j, kX1);
    }
    double c00 = 0.0, c01 = 0.0, c11 = 0.0;
    for (int j = 0; j < n; ++j) {
      const double mu = std::exp(at(j, kLogMu));
      if (mu == 0.0) continue;
      const double d0 = at(j, kX0) - mean0, d1 = at(j, kX1) - mean1;
      c00 += mu * (at(j, kP00) + d0 * d0);
      c01 += mu * (at(j, kP01) + d0 * d1);
      c11 += mu * (at(j, kP11) + d1 * d1);
    }
    axes[static_cast<std::size_t>(axis)] = {mean0, mean1, c00, c01, c11};
  }
  return bank::two_axis_estimate(t, [&](int e, std::ptrdiff_t lane) {
    return axes[static_cast<std::size_t>(lane - 2 * t)][static_cast<std::size_t>(e)];
  });
}

ModeVector FcmImmTrackBank::mode_probabilities(std::size_t track) const {
  const std::ptrdiff_t t = checked(track);
  const int n = spec_.mode_count();
  ModeVector mu(2 * n);
  for (int axis = 0; axis < 2; ++axis) {
    for (int j = 0; j < n; ++j) {
      mu(axis * n + j) = std::exp(slot(j * mode_slots_ + kLogMu)[2 * t + axis]);
    }
  }
  return mu;
}

}  // namespace imm
