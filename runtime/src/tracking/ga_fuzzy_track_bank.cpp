// SPDX-License-Identifier: Apache-2.0
// The GA-fuzzy IMM bank: axis filters as lanes, blocks of kBlock lanes stepped as packs (see the
// header): imm_cycle.hpp's IMM cycle with fuzzy_noise_step.hpp's step as the family's.
#include "imm/tracking/ga_fuzzy_track_bank.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "axis_lane_bank.hpp"
#include "axis_lane_cycle.hpp"
#include "axis_lane_gating.hpp"
#include "bank_checks.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/math/lane_isa.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"

namespace imm {
namespace {

using bank::kNonFinite, bank::kOk, bank::kSingular;

// The GA-fuzzy IMM's fuzzy-noise modes of one axis as imm_cycle.hpp's family: a mode holds its
// estimate [x0, x1, p00, p01, p11] and its table's last first input; its step is
// fuzzy_noise_steps over packs (FuzzyLevelConstants); a track is two lanes, x then y.
struct FuzzyNoiseFamily : bank::AxisLaneFamily {
  static constexpr int kEntries = 6, kPrevious = 5;
  template <class S>
  using Plot = S;
  template <class S>
  using Mode = std::array<S, kEntries>;
  const lanes::FuzzyAxisConstants* axis = nullptr;
  const lanes::FuzzyLevelConstants* levels = nullptr;

  // Mode j's fuzzy-noise steps of K packs together; ℓ_j = log N(r; 0, S).
  template <class S, int K>
  [[gnu::always_inline]] inline void steps(int j, const Estimate<S> (&mixed)[K],
                                           const Mode<S> (&current)[K], const S (&z)[K],
                                           Mode<S> (&updated)[K], S (&log_likelihood)[K],
                                           S (&code)[K]) const {
    S previous[K];
    lanes::AxisEstimateOf<S> start[K];
    for (int k = 0; k < K; ++k) {
      previous[k] = current[k][kPrevious];
      start[k] = {mixed[k][0], mixed[k][1], mixed[k][2], mixed[k][3], mixed[k][4]};
    }
    lanes::FuzzyNoiseStep<S> s[K];
    lanes::fuzzy_noise_steps<S, K>(*axis, levels[j], z, previous, start, s);
    // The mode's kept innovation (FuzzyNoiseFilter: r and S).
    record_innovations<S, K>(
        j, [&](int k) { return s[k].residual; }, [&](int k) { return s[k].s; });
    for (int k = 0; k < K; ++k) {
      const lanes::AxisEstimateOf<S>& e = s[k].estimate;
      updated[k] = {e.x0, e.x1, e.p00, e.p01, e.p11, s[k].antecedent};
      log_likelihood[k] = -0.5 * (s[k].mahalanobis + lane_log(s[k].s) + kLogTwoPi);
      code[k] = pick(s[k].usable, pick(s[k].finite, kOk, kNonFinite), kSingular);
    }
  }

  // Mode j's prediction without a plot (FuzzyNoiseFilter::predict_only: the table's mean w as q):
  // ẑ_j and S_j = P⁻₀₀ + R (axis_lane_gating.hpp).
  void predicted_plot(int j, const Estimate<double>& mixed, double& z_hat, double& variance) const {
    const lanes::AxisEstimate p =
        lanes::cv_predict(axis->T, {mixed[0], mixed[1], mixed[2], mixed[3], mixed[4]});
    z_hat = p.x0;
    variance = p.p00 + levels[j].mean_w * axis->g00 + axis->R;
  }
};

// step_block for each instruction set, its pack one vector of it (lane_isa.hpp).
// NOLINTBEGIN(bugprone-macro-parentheses): `target` is an attribute.
#define IMM_BLOCK_FOR(isa, target, width)                                               \
  template <int W, int N>                                                               \
  [[gnu::flatten]] target void step_block_##isa(                                        \
      const FuzzyNoiseFamily& family, const bank::CycleBlock& b, std::ptrdiff_t first,  \
      const double* z, const double* stepped, double* code) {                           \
    bank::axis_lane_cycle<LanePackOf<width>, W, N>(family, b, first, z, stepped, code); \
  }
IMM_FOR_EACH_LANE_ISA(IMM_BLOCK_FOR)
#undef IMM_BLOCK_FOR
// NOLINTEND(bugprone-macro-parentheses)

// The spec's Π, once the spec is valid and every entry is positive (see the header).
Eigen::MatrixXd checked_transition(const GaFuzzyImmSpec& spec) {
  spec.validate();
  Eigen::MatrixXd transition = spec.settings.transition(static_cast<int>(spec.levels.size()));
  if (!(transition.array() > 0.0).all()) {
    throw InvalidParameter("settings.transition_stay",
                           "the GA-fuzzy track bank needs every transition probability positive "
                           "(transition_stay below 1 with more than one level)");
  }
  return transition;
}

}  // namespace

GaFuzzyTrackBank::GaFuzzyTrackBank(const GaFuzzyImmSpec& spec, std::size_t capacity,
                                   bool wide_blocks)
    // The braces evaluate in order: the spec is checked before its probabilities are read.
    : AxisImmLaneStorage("GaFuzzyTrackBank",
                         {checked_transition(spec), spec.settings.initial_probabilities(
                                                        static_cast<int>(spec.levels.size()))},
                         FuzzyNoiseFamily::kEntries),
      wide_blocks_(wide_blocks) {
  allocate_modes(capacity, kBlock, FuzzyNoiseFamily::kCombined);
  for (const FuzzyLevel& level : spec.levels) levels_.emplace_back(level.table);
  axis_ = lanes::FuzzyAxisConstants(
      spec.settings.sample_period,
      spec.settings.measurement_sigma * spec.settings.measurement_sigma, spec.antecedents);
  scratch_.assign(std::size_t{3} * kBlock, 0.0);
  innovations_.assign(bank::ModeInnovations::kSize, 0.0);
}

void GaFuzzyTrackBank::initialize(std::size_t track, const GaussianState<4>& state) {
  // ImmEstimator::initialize: every mode takes the state (the tables' previous input 0), then
  // the combination with μ_j(0).
  const std::ptrdiff_t t = start_modes(track, state);
  const ModeVector mu = initial_probabilities();
  for (int axis = 0; axis < 2; ++axis) {
    const std::array<double, 5> values = bank::axis_entries(state, axis);
    std::array<double, 5> combined{};
    bank::collapse_axis(
        mode_count(), mu.data(), [&](int /*j*/) -> const std::array<double, 5>& { return values; },
        combined);
    for (int e = 0; e < 5; ++e) slot(slots_after_modes() + e)[2 * t + axis] = combined[e];
  }
  mark_initialized(t);
}

void GaFuzzyTrackBank::step_lanes(const LaneStep& call) {
  FuzzyNoiseFamily family{{}, &axis_, levels_.data()};
  const bank::CycleBlock cycle{mode_count(), transition(), log_transition(), slot(0), stride()};
  const bank::ModeInnovations innovations(innovations_.data());
  if (call.nis != nullptr) family.record = &innovations;
  // The instruction set's function for the mode count and block width, chosen outside it (a
  // lambda inside a function compiled for an instruction set is compiled for the baseline).
  const LaneIsa isa = lane_isa();
  bank::with_mode_count(mode_count(), [&](auto n) {
    bank::step_blocks<kBlock>(
        call.plots, call.status, wide_blocks_, scratch_.data(),
        [&](auto width, std::size_t first, const double* z, const double* stepped, double* code) {
          constexpr int W = decltype(width)::value, N = decltype(n)::value;
          const auto lane = static_cast<std::ptrdiff_t>(first);
          bank::step_stating_nis<FuzzyNoiseFamily>(
              cycle, innovations, W, first / 2, call.plots.size(), code, call.nis, [&] {
                for_lane_isa(isa, step_block_avx512<W, N>, step_block_avx2<W, N>,
                             step_block_baseline<W, N>)(family, cycle, lane, z, stepped, code);
              });
        });
  });
}

void GaFuzzyTrackBank::score_lanes(const LaneScore& call) {
  const FuzzyNoiseFamily family{{}, &axis_, levels_.data()};
  const bank::CycleBlock cycle{mode_count(), transition(), log_transition(), slot(0), stride()};
  bank::with_mode_count(mode_count(), [&](auto n) {
    bank::score_tracks<decltype(n)::value, FuzzyNoiseFamily>(
        cycle, [&](Eigen::Index /*track*/) { return family; }, call);
  });
}

GaussianState<4> GaFuzzyTrackBank::estimate(std::size_t track) const {
  return bank::two_axis_estimate(checked(track), [&](int e, std::ptrdiff_t lane) {
    return slot(slots_after_modes() + e)[lane];
  });
}

}  // namespace imm
