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
#include "two_mode_innovations.hpp"
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

// One scan of one block's W tracks (bank::BlockStep: the plots in the sensor's (z1, z2)).
template <int W>
[[gnu::flatten]] IMM_VECTOR_CLONES void step_block(const double (&p)[2][2],
                                                   const fimm::Constants& b,
                                                   const bank::BlockStep& block) {
  auto st = [&](int entry) { return block.slot(entry); };
  bank::Mixing<W> mixing;  // NOLINT(cppcoreguidelines-pro-type-member-init): written first
  fimm::Mode<W> modes[2];
  predict_block<W>(p, b, st, mixing, modes);
  for (int j = 0; j < 2; ++j) fimm::update<W>(b, block.z0, block.z1, modes[j]);
  double commit[W];
  // The plot is the measurement the modes updated with: no rewrite for the NIS.
  bank::finish_and_keep<kAxis, kAxis, W>(
      mixing, kModes, kLogMu, modes[0], modes[1], block,
      [](int /*l*/, Eigen::Vector2d& /*nu*/, Eigen::Matrix2d& /*S*/) {}, commit);
}

// The gating matrix of one block's tracks (`g`): the mixing and both predictions once, then per
// plot both modes' first linearization at the prediction and update over the block (nothing
// kept: the candidate questions of PositionKalmanMode, whose prediction does not read the plot),
// and each track's answer into g's columns.
template <int W>
[[gnu::flatten]] IMM_VECTOR_CLONES void score_block(const double (&p)[2][2],
                                                    const fimm::Constants& b,
                                                    const bank::GatingBlock& g) {
  auto st = [&](int entry) { return g.slot(entry); };
  bank::Mixing<W> mixing;  // NOLINT(cppcoreguidelines-pro-type-member-init): written first
  fimm::Mode<W> modes[2];
  predict_block<W>(p, b, st, mixing, modes);
  bank::score_plots<kAxis, kAxis, W>(
      mixing, modes[0], modes[1], g,
      [&](const Eigen::Vector2d& z, bank::Linearization<W>(&lin)[2]) {
        double z0[W], z1[W];
        IMM_LANES {
          z0[l] = z(0);
          z1[l] = z(1);
        }
        for (int j = 0; j < 2; ++j) fimm::linearize<W>(b, z0, z1, modes[j], modes[j].x, lin[j]);
      });
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

void FimmTrackBank::step_lanes(const LaneStep& call) {
  bank::step_blocks<kBlock>(call.plots, call.status, Eigen::Vector2d::Zero(), slot(0), stride(),
                            call.nis, [&](const bank::BlockStep& block) {
                              step_block<kBlock>(constants_->p, constants_->b, block);
                            });
}

void FimmTrackBank::score_lanes(const LaneScore& call) {
  bank::score_in_blocks<kBlock>(call.plots, call.gate, call.gate_scale, slot(0), stride(), call.out,
                                [&](const bank::GatingBlock& block) {
                                  score_block<kBlock>(constants_->p, constants_->b, block);
                                });
}

}  // namespace imm
