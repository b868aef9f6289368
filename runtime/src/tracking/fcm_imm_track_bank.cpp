// SPDX-License-Identifier: Apache-2.0
// 64-byte vectors by value inside this file only (lane_math.hpp says why that is harmless).
#pragma GCC diagnostic ignored "-Wpsabi"
// The FCM-IMM's bank: axis filters as lanes, blocks of kBlock lanes (see the header). The IMM
// cycle is imm_cycle.hpp's, every bank's; each mode's step is fcm_mode_step.hpp's over a pack, the
// one FcmCompensatedMode::propose runs for a double, with the memberships between its halves.
#include "imm/tracking/fcm_imm_track_bank.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "axis_lane_bank.hpp"
#include "axis_lane_cycle.hpp"
#include "axis_lane_gating.hpp"
#include "bank_checks.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/filters/fcm_mode_step.hpp"
#include "imm/filters/fuzzy_noise_step.hpp"
#include "imm/math/lane_isa.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"

namespace imm {
namespace {

using bank::kNonFinite, bank::kOk, bank::kSingular;
using lanes::kMaxLevels;
// A mode's window slots, after every mode's cycle slots: the ring's head and size, whether it has
// centers, the centers, then the errors, oldest at head.
constexpr int kHead = 0, kSize = 1, kHasCenters = 2, kCenters = 3, kRing = 6;

struct BankConstants {
  int modes, window;
  lanes::FcmModeConstants mode[kMaxLevels];  // each mode's step
  bool constant;
  ClusterVector constant_u[kMaxLevels];
  ClusterVector lower, upper;
  FuzzyCMeansSettings clustering;
  double* window_scratch;  // window doubles, then 3 window memberships
};

// The constants of a spec's cycle; `window_scratch` the bank's scratch.
BankConstants bank_constants(const FcmImmSpec& spec, double* window_scratch) {
  BankConstants b{};
  b.modes = spec.mode_count();
  b.window = spec.window;
  for (int j = 0; j < b.modes; ++j) {
    b.mode[j] = fcm_mode_constants(spec, j);
    if (spec.constant_memberships) b.constant_u[j] = spec.mean_memberships.row(j).transpose();
  }
  b.constant = spec.constant_memberships;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  b.lower = ClusterVector::Constant(-kInf);
  b.upper = ClusterVector::Constant(kInf);
  if (spec.scale == MembershipScale::kInnovation) {
    b.upper(0) = -spec.separation;
    b.lower(1) = b.upper(1) = 0.0;
    b.lower(2) = spec.separation;
  }
  b.clustering = spec.clustering;
  b.window_scratch = window_scratch;
  return b;
}

// What a block's cycle leaves for the windows' commit, per mode and lane: the error the window
// takes and the pending clustering.
struct Pending {
  double error[kMaxLevels][FcmImmTrackBank::kBlock];
  double centers[kMaxLevels][kFcmClusters][FcmImmTrackBank::kBlock];
  double clustered[kMaxLevels][FcmImmTrackBank::kBlock];
};

// The FCM-IMM's modes of one axis as imm_cycle.hpp's family, for one block of lanes: a mode holds
// its estimate [x0, x1, p00, p01, p11]; its step is fcm_predict, the memberships of its new error
// in its window (lane by lane) and fcm_update; a track is two lanes, x then y.
struct FcmFamily : bank::AxisLaneFamily {
  static constexpr int kEntries = 5;
  static constexpr bool kStoresCombined = false;  // estimate() combines the modes
  // The window clustering's stopping rule makes a mode's step discontinuous in its mixed
  // condition: μ's exp and log are the one-track filter's (libm's).
  static constexpr bool kLibmProbabilities = true;
  template <class S>
  using Plot = S;
  const BankConstants* b = nullptr;
  const double* stepped = nullptr;  // the block's lanes: 1 for a lane to step
  double* windows = nullptr;        // the block's first lane of mode 0's first window slot
  std::ptrdiff_t stride = 0, window_slots = 0;
  Pending* pending = nullptr;

  // Window slot `entry` of mode j, at the block's first lane.
  [[nodiscard]] double* at(int j, int entry) const {
    return windows + (j * window_slots + entry) * stride;
  }

  // Mode j's step of K packs: fcm_predict, the memberships (SlidingFuzzyCMeans::propose; none
  // where the step cannot succeed: an unusable plot or S), fcm_update with c = fcm_compensation
  // (λ (1 − u_noise)); ℓ_j = log N(e; 0, S).
  template <class S, int K>
  [[gnu::always_inline]] inline void steps(int j, const Estimate<S> (&mixed)[K],
                                           const Estimate<S> (&/*current*/)[K], const S (&z)[K],
                                           Estimate<S> (&updated)[K], S (&log_likelihood)[K],
                                           S (&code)[K]) const {
    constexpr int L = kLanesOf<S>, W = K * L;
    lanes::FcmPrediction<S> predicted[K];
    double usable[W], u1[W];
    for (int k = 0; k < K; ++k) {
      const Estimate<S>& m = mixed[k];
      predicted[k] = lanes::fcm_predict<S>(b->mode[j], {m[0], m[1], m[2], m[3], m[4]}, z[k]);
      const std::ptrdiff_t lane = static_cast<std::ptrdiff_t>(k) * L;
      lane_store(pending->error[j] + lane, predicted[k].clustered);
      lane_store(usable + lane, pick(predicted[k].usable, splat<S>(1.0), splat<S>(0.0)));
    }
    // The mode's kept innovation (FcmCompensatedMode: e and S).
    record_innovations<S, K>(
        j, [&](int k) { return predicted[k].error; }, [&](int k) { return predicted[k].s; });
    for (int l = 0; l < W; ++l) {
      pending->clustered[j][l] = 0.0;
      u1[l] = 1.0;
      if (b->constant) {
        u1[l] = b->constant_u[j](1);
        continue;
      }
      const double x = pending->error[j][l];
      const int size = static_cast<int>(at(j, kSize)[l]);
      const int kept = std::min(size, b->window - 1);
      if (!(stepped[l] != 0.0 && std::isfinite(x) && usable[l] != 0.0) || kept + 1 < kFcmClusters) {
        continue;
      }
      const int head = static_cast<int>(at(j, kHead)[l]), skip = size - kept;
      double* window = b->window_scratch;
      for (int i = 0; i < kept; ++i) window[i] = at(j, kRing + (head + skip + i) % b->window)[l];
      window[kept] = x;
      const auto points = static_cast<std::size_t>(kept) + 1;
      const ClusterVector previous(at(j, kCenters)[l], at(j, kCenters + 1)[l],
                                   at(j, kCenters + 2)[l]);
      ClusterVector centers;
      int iterations = 0;
      const ClusterVector u = cluster_window(
          std::span<const double>(window, points),
          at(j, kHasCenters)[l] != 0.0 ? &previous : nullptr, b->lower, b->upper, b->clustering,
          std::span<double>(window + b->window, kFcmClusters * points), centers, iterations);
      u1[l] = u(1);
      for (int c = 0; c < kFcmClusters; ++c) pending->centers[j][c][l] = centers(c);
      pending->clustered[j][l] = 1.0;
    }
    for (int k = 0; k < K; ++k) {
      const S compensation = lanes::fcm_compensation(
          b->mode[j], lane_load<S>(u1 + static_cast<std::ptrdiff_t>(k) * L));
      const lanes::FcmUpdate<S> u = lanes::fcm_update<S>(b->mode[j], predicted[k], compensation);
      const lanes::AxisEstimateOf<S>& e = u.updated;
      updated[k] = {e.x0, e.x1, e.p00, e.p01, e.p11};
      log_likelihood[k] = u.log_likelihood;
      code[k] = pick(u.factored, pick(u.finite, kOk, kNonFinite), kSingular);
    }
  }

  // Mode j's prediction without a plot (FcmCompensatedMode::propose_prediction: no compensation,
  // the window left alone): ẑ_j and S_j = P⁻₀₀ + R (axis_lane_gating.hpp).
  void predicted_plot(int j, const Estimate<double>& mixed, double& z_hat, double& variance) const {
    const lanes::AxisEstimate p =
        lanes::fcm_prior<double>(b->mode[j], {mixed[0], mixed[1], mixed[2], mixed[3], mixed[4]});
    z_hat = p.x0;
    variance = p.p00 + b->mode[j].R;
  }
};

// One IMM cycle of one block's W lanes (whole packs) of an FCM-IMM of N modes from lane `first`
// (axis_lane_cycle.hpp). Then the committed lanes' windows take the new error, their centers the
// clustering's (SlidingFuzzyCMeans::commit); the ablation's constant memberships keep no window.
template <class Pack, int W, int N>
[[gnu::always_inline]] inline void step_block(const FcmFamily& family, const bank::CycleBlock& b,
                                              std::ptrdiff_t first, const double* z,
                                              const double* stepped, double* code) {
  bank::axis_lane_cycle<Pack, W, N>(family, b, first, z, stepped, code);
  const BankConstants& c = *family.b;
  if (c.constant) return;
  for (int j = 0; j < b.modes; ++j) {
    for (int l = 0; l < W; ++l) {
      if (!(stepped[l] != 0.0 && code[l] == kOk)) continue;
      auto at = [&](int entry) -> double& { return family.at(j, entry)[l]; };
      const int size = static_cast<int>(at(kSize));
      const int head = static_cast<int>(at(kHead));
      const double error = family.pending->error[j][l];
      if (size < c.window) {
        at(kRing + (head + size) % c.window) = error;
        at(kSize) = size + 1;
      } else {
        at(kRing + head) = error;
        at(kHead) = (head + 1) % c.window;
      }
      if (family.pending->clustered[j][l] != 0.0) {
        for (int e = 0; e < kFcmClusters; ++e) at(kCenters + e) = family.pending->centers[j][e][l];
        at(kHasCenters) = 1.0;
      }
    }
  }
}

// The spec's Π, once the spec is valid and every entry is positive (see the header).
const Eigen::MatrixXd& checked_transition(const FcmImmSpec& spec) {
  spec.validate();
  bank::require_positive_transitions(spec.transition);
  return spec.transition;
}

// step_block for each instruction set, its pack one vector of it (lane_isa.hpp).
// NOLINTBEGIN(bugprone-macro-parentheses): `target` is an attribute.
#define IMM_BLOCK_FOR(isa, target, width)                                                        \
  template <int W, int N>                                                                        \
  [[gnu::flatten]] target void step_block_##isa(                                                 \
      const FcmFamily& family, const bank::CycleBlock& b, std::ptrdiff_t first, const double* z, \
      const double* stepped, double* code) {                                                     \
    step_block<LanePackOf<width>, W, N>(family, b, first, z, stepped, code);                     \
  }
IMM_FOR_EACH_LANE_ISA(IMM_BLOCK_FOR)
#undef IMM_BLOCK_FOR
// NOLINTEND(bugprone-macro-parentheses)

}  // namespace

FcmImmTrackBank::FcmImmTrackBank(const FcmImmSpec& spec, std::size_t capacity)
    // The braces evaluate in order: the spec is checked before its probabilities are read.
    : AxisImmLaneStorage("FcmImmTrackBank", {checked_transition(spec), spec.initial_probabilities},
                         FcmFamily::kEntries),
      spec_(spec),
      window_slots_(kRing + spec.window) {
  allocate_modes(capacity, kBlock, static_cast<std::size_t>(spec.mode_count()) * window_slots_);
  scratch_.assign(
      static_cast<std::size_t>(1 + kFcmClusters) * static_cast<std::size_t>(spec.window), 0.0);
  innovations_.assign(bank::ModeInnovations::kSize, 0.0);
}

void FcmImmTrackBank::initialize(std::size_t track, const GaussianState<4>& state) {
  // Every mode takes the state, μ its initial value, the clusterings empty windows.
  const std::ptrdiff_t t = start_modes(track, state);
  for (int axis = 0; axis < 2; ++axis) {
    for (int j = 0; j < mode_count(); ++j) {
      auto window = [&](int entry) -> double& { return slot(window_slot(j, entry))[2 * t + axis]; };
      window(kHead) = window(kSize) = window(kHasCenters) = 0.0;
      for (int c = 0; c < kFcmClusters; ++c) window(kCenters + c) = 0.0;
    }
  }
  mark_initialized(t);
}

int FcmImmTrackBank::window_slot(int mode, int entry) const {
  return slots_after_modes() + mode * window_slots_ + entry;
}

void FcmImmTrackBank::step_lanes(const LaneStep& call) {
  const bank::ModeInnovations innovations(innovations_.data());
  const BankConstants b = bank_constants(spec_, scratch_.data());
  const bank::CycleBlock cycle{b.modes, transition(), log_transition(), slot(0), stride()};
  Pending pending;  // NOLINT(cppcoreguidelines-pro-type-member-init): each step writes its lanes'
  double lanes[3 * kBlock];  // one block's plots, flags and codes
  // The instruction set's function for the mode count, chosen outside it (a lambda inside a
  // function compiled for an instruction set is compiled for the baseline).
  const LaneIsa isa = lane_isa();
  bank::with_mode_count(b.modes, [&](auto n) {
    constexpr int N = decltype(n)::value;
    const auto block = for_lane_isa(isa, step_block_avx512<kBlock, N>, step_block_avx2<kBlock, N>,
                                    step_block_baseline<kBlock, N>);
    bank::step_blocks<kBlock>(
        call.plots, call.status, true, lanes,
        [&](auto /*width*/, std::size_t first, const double* z, const double* stepped,
            double* code) {
          const auto lane = static_cast<std::ptrdiff_t>(first);
          FcmFamily family{
              {}, &b, stepped, slot(window_slot(0, 0)) + lane, stride(), window_slots_, &pending};
          if (call.nis != nullptr) family.record = &innovations;
          bank::step_stating_nis<FcmFamily>(cycle, innovations, kBlock, first / 2,
                                            call.plots.size(), code, call.nis,
                                            [&] { block(family, cycle, lane, z, stepped, code); });
        });
  });
}

void FcmImmTrackBank::score_lanes(const LaneScore& call) {
  const BankConstants b = bank_constants(spec_, scratch_.data());
  const bank::CycleBlock cycle{b.modes, transition(), log_transition(), slot(0), stride()};
  // NOLINTNEXTLINE(cppcoreguidelines-pro-type-member-init): a trial writes its two lanes first
  Pending pending;
  const double stepped[2] = {1.0, 1.0};  // a track's two lanes
  bank::with_mode_count(b.modes, [&](auto n) {
    bank::score_tracks<decltype(n)::value, FcmFamily>(
        cycle,
        [&](Eigen::Index t) {
          return FcmFamily{
              {}, &b, stepped, slot(window_slot(0, 0)) + 2 * t, stride(), window_slots_, &pending};
        },
        call);
  });
}

GaussianState<4> FcmImmTrackBank::estimate(std::size_t track) const {
  // Per axis, the modes moment-matched with μ = exp(log μ) (ImmEstimator::combine).
  const ModeVector mu = mode_probabilities(track);
  const auto t = static_cast<std::ptrdiff_t>(track);
  const int n = mode_count();
  std::array<std::array<double, 5>, 2> axes{};
  for (int axis = 0; axis < 2; ++axis) {
    std::array<std::array<double, 5>, kMaxLevels> modes{};
    for (int j = 0; j < n; ++j) {
      for (int e = 0; e < 5; ++e)
        modes[static_cast<std::size_t>(j)][static_cast<std::size_t>(e)] =
            slot(mode_slot(j, e))[2 * t + axis];
    }
    const double* weights = mu.data() + static_cast<std::ptrdiff_t>(axis) * n;
    bank::collapse_axis(
        n, weights,
        [&](int j) -> const std::array<double, 5>& { return modes[static_cast<std::size_t>(j)]; },
        axes[static_cast<std::size_t>(axis)]);
  }
  return bank::two_axis_estimate(t, [&](int e, std::ptrdiff_t lane) {
    return axes[static_cast<std::size_t>(lane - 2 * t)][static_cast<std::size_t>(e)];
  });
}

}  // namespace imm
