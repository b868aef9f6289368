// SPDX-License-Identifier: Apache-2.0
// The FIMM's bank: tracks as lanes, blocks of kBlock tracks (see the header). Each mode's step is
// the one-track FIMM's mode step (fimm_step.hpp) over the block's lanes; the mixing, the
// posterior and the commit follow ImmEstimator::step (two_mode_lanes.hpp).
#include "imm/tracking/fimm_track_bank.hpp"

#include <algorithm>
#include <array>
#include <limits>
#include <utility>

#include "bank_checks.hpp"
#include "filters/fimm_step.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/math/lane_math.hpp"
#include "two_mode_lanes.hpp"

namespace imm {
namespace {

using fimm::kAxis;
// State slots per track: each mode's mean [ξ, ξ̇, ξ̈, η, η̇, η̈] and its covariance's upper
// triangle (row by row), then log μ (cruise, lane change).
constexpr std::array<bank::ModeSlots, 2> kModes{bank::ModeSlots{kAxis, 0, 6},
                                                bank::ModeSlots{kAxis, 27, 33}};
constexpr int kLogMu = 54, kSlots = 56;

// The mixing and both modes' predictions of a block (each mode's prediction reads only the
// mixing, so both are made before either updates).
template <int W, class Slot>
[[gnu::always_inline]] inline void predict_block(const double (&p)[2][2], const fimm::Constants& b,
                                                 Slot&& st, bank::Mixing<W>& mixing,
                                                 fimm::Mode<W> (&modes)[2]) {
  bank::mix_and_predict_both<kAxis, kAxis, W>(p, kModes, kLogMu, st, b.modes[0], b.modes[1], mixing,
                                              modes[0], modes[1]);
}

// One scan of one block's W tracks. `state` points at the block's first track of slot 0; `z0`
// and `z1` the plots (NaN: unusable); `stepped` 1 for a track to step; `code` receives each
// track's outcome; where `nis` is not null, its first `lanes` entries the tracks' NIS.
template <int W>
[[gnu::flatten]] IMM_VECTOR_CLONES void step_block(const double (&p)[2][2],
                                                   const fimm::Constants& b, double* state,
                                                   std::ptrdiff_t stride, const double* z0,
                                                   const double* z1, const double* stepped,
                                                   double* code, double* nis, int lanes) {
  auto st = [&](int entry) { return state + entry * stride; };
  bank::Mixing<W> mixing;  // NOLINT(cppcoreguidelines-pro-type-member-init): written first
  fimm::Mode<W> modes[2];
  predict_block<W>(p, b, st, mixing, modes);
  for (int j = 0; j < 2; ++j) fimm::update<W>(b, z0, z1, modes[j]);
  double usable[W], commit[W], log_mu[2][W];
  IMM_LANES usable[l] = pick((z0[l] == z0[l]) & (z1[l] == z1[l]), 1.0, 0.0);
  bank::finish<kAxis, kAxis, W>(mixing, modes[0], modes[1], usable, stepped, log_mu, code, commit);
  if (nis != nullptr) {  // the plot is the measurement the modes updated with
    bank::step_nis<kAxis, kAxis, W>(
        mixing, modes[0], modes[1], code, lanes,
        [](int /*l*/, Eigen::Vector2d& /*nu*/, Eigen::Matrix2d& /*S*/) {}, nis);
  }
  bank::keep<W>(st, kLogMu, log_mu[0], commit);
  bank::keep<W>(st, kLogMu + 1, log_mu[1], commit);
  for (int j = 0; j < 2; ++j) {
    bank::keep_mode<kAxis, W>(st, kModes[static_cast<std::size_t>(j)], modes[j], commit);
  }
}

// The gating matrix of one block's tracks (`g`): the mixing and both predictions once, then per
// plot both modes' first linearization at the prediction and update over the block (nothing
// kept: the candidate questions of PositionKalmanMode, whose prediction does not read the plot),
// and each track's answer into g's columns.
template <int W>
[[gnu::flatten]] IMM_VECTOR_CLONES void score_block(const double (&p)[2][2],
                                                    const fimm::Constants& b, double* state,
                                                    std::ptrdiff_t stride,
                                                    const bank::GatingBlock& g) {
  auto st = [&](int entry) { return state + entry * stride; };
  bank::Mixing<W> mixing;  // NOLINT(cppcoreguidelines-pro-type-member-init): written first
  fimm::Mode<W> modes[2];
  predict_block<W>(p, b, st, mixing, modes);
  double c[2][W];
  bank::normalized_predicted<W>(mixing, c);
  for (std::size_t q = 0; q < g.plots.size(); ++q) {
    double* column = g.out + static_cast<std::ptrdiff_t>(q) * g.out_stride;
    const Eigen::Vector2d& z = g.plots[q];
    if (!limits::usable_measurement(z)) {
      std::fill(column, column + g.lanes, std::numeric_limits<double>::quiet_NaN());
      continue;
    }
    double z0[W], z1[W];
    IMM_LANES {
      z0[l] = z(0);
      z1[l] = z(1);
    }
    bank::Linearization<W> lin[2];  // NOLINT(cppcoreguidelines-pro-type-member-init)
    for (int j = 0; j < 2; ++j) fimm::linearize<W>(b, z0, z1, modes[j], modes[j].x, lin[j]);
    if (bank::all_outside_the_gate<kAxis, kAxis, W>(c, lin[0], modes[0], lin[1], modes[1], g)) {
      std::fill(column, column + g.lanes, -std::numeric_limits<double>::infinity());
      continue;
    }
    for (int j = 0; j < 2; ++j) bank::update_mode<kAxis, W>(lin[j], modes[j]);
    for (int l = 0; l < g.lanes; ++l) {
      column[l] =
          bank::candidate_answer<kAxis, kAxis, W>(mixing, c, modes[0], modes[1], l, g.gate_of(l));
    }
  }
}

}  // namespace

// The kernel's constants, made once per bank.
struct FimmTrackBank::Constants {
  double p[2][2] = {};  // Π
  fimm::Constants b;
};

FimmTrackBank::FimmTrackBank(const FimmSpec& spec, std::shared_ptr<const TskSensorModel> sensor,
                             std::size_t capacity)
    : TwoModeLaneStorage("FimmTrackBank", {kModes[0].d, kModes[0].mean, kModes[0].covariance},
                         {kModes[1].d, kModes[1].mean, kModes[1].covariance}, kLogMu),
      spec_(spec),
      sensor_(std::move(sensor)) {
  spec.validate();
  bank::require_positive_transitions(spec.transition);
  allocate(capacity, 1, kBlock, kSlots);
  auto constants = std::make_shared<Constants>();
  bank::transitions_into(spec.transition, constants->p);
  constants->b = fimm::constants_of(spec, sensor_.get());
  constants_ = std::move(constants);
}

void FimmTrackBank::initialize(std::size_t track, const GaussianState<6>& state) {
  mark_initialized(start(track, state, spec_.initial_probabilities));
}

void FimmTrackBank::step_lanes(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status,
                               double* nis) {
  bank::step_blocks<kBlock>(
      plots, status, Eigen::Vector2d::Zero(),
      [&](std::size_t first, const double* z0, const double* z1, const double* stepped,
          double* code) {
        const int lanes = static_cast<int>(std::min<std::size_t>(kBlock, plots.size() - first));
        step_block<kBlock>(constants_->p, constants_->b, slot(0) + first, stride(), z0, z1, stepped,
                           code, nis == nullptr ? nullptr : nis + first, lanes);
      });
}

void FimmTrackBank::score_lanes(
    std::span<const Eigen::Vector2d> plots, double gate, const double* gate_scale,
    Eigen::Ref<Eigen::MatrixXd> out) {  // NOLINT(performance-unnecessary-value-param)
  bank::score_in_blocks<kBlock>(
      plots, gate, gate_scale, out, [&](std::ptrdiff_t first, const bank::GatingBlock& block) {
        score_block<kBlock>(constants_->p, constants_->b, slot(0) + first, stride(), block);
      });
}

}  // namespace imm
