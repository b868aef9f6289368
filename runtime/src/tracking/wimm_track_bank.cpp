// SPDX-License-Identifier: Apache-2.0
// The weighted IMM's bank: tracks as lanes, blocks of kBlock tracks stepped in three phases (see
// the header). The measurement and the modes' steps are the one-track WimmFilter's (wimm_step.hpp,
// position_kalman_step.hpp) over the block's lanes; the mixing, the posterior and the commit
// follow ImmEstimator::step_with (two_mode_lanes.hpp).
#include "imm/tracking/wimm_track_bank.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include "bank_checks.hpp"
#include "filters/wimm_step.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/math/angle.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/models/measurement/polar_measurement.hpp"
#include "two_mode_innovations.hpp"
#include "two_mode_lanes.hpp"

namespace imm {
namespace {

using wimm::kCvAxis;
using wimm::kSingerAxis;
// State slots per track: the CV mode's mean [x, vx, y, vy] and its covariance's upper triangle
// (row by row), the Singer mode's mean [x, vx, ax, y, vy, ay] and upper triangle, log μ (CV,
// Singer), and whether the last step fused.
constexpr bank::ModeSlots kCv{kCvAxis, 0, 4}, kSinger{kSingerAxis, 14, 20};
constexpr std::array<bank::ModeSlots, 2> kModes{kCv, kSinger};
constexpr int kLogMu = 41, kFused = 43, kSlots = 44;

// The first phase of a block's cycle: the mixing, both modes' predictions and their predicted
// ranges and azimuths (per mode j: the predicted position px, py, r and its azimuth).
template <int W>
struct Predicted {
  bank::Mixing<W> mixing;
  // Every field is written before it is read; zeroing them first would cost.
  bank::ModeLanes<kCvAxis, W> cv;
  bank::ModeLanes<kSingerAxis, W> singer;
  double px[2][W], py[2][W], r[2][W], predicted_azimuth[2][W];
};

template <int W, class Slot>
[[gnu::always_inline]] inline void predict_block(const double (&p)[2][2], const wimm::Constants& b,
                                                 Slot&& st, Predicted<W>& m) {
  bank::mix_and_predict_both<kCvAxis, kSingerAxis, W>(p, kModes, kLogMu, st, b.cv, b.singer,
                                                      m.mixing, m.cv, m.singer);
  for (int j = 0; j < 2; ++j) {
    const double* x = j == 0 ? m.cv.x[0] : m.singer.x[0];
    const double* y = j == 0 ? m.cv.x[wimm::kCvAxis] : m.singer.x[wimm::kSingerAxis];
    IMM_LANES {
      m.px[j][l] = x[l];
      m.py[j][l] = y[l];
    }
    wimm::range_and_azimuth<W>(x, y, m.r[j], m.predicted_azimuth[j]);
  }
}

// A mode's innovation ν and S of the update with the fused azimuth `chosen` rewritten into the
// plot's (range, azimuth), as WimmFilter::to_plot does; unchanged where the track did not fuse.
void to_plot(const wimm::Constants& b, bool fused, double range, double azimuth, double chosen,
             Eigen::Vector2d& nu, Eigen::Matrix2d& S) {
  if (!fused) return;
  if (b.converted) {
    const Eigen::Matrix2d R = Eigen::Vector2d(b.range_variance, b.azimuth_variance).asDiagonal();
    const CartesianPlot plot = polar_to_cartesian(Vector<2>(range, azimuth), R);
    const CartesianPlot fused_plot = polar_to_cartesian(Vector<2>(range, chosen), R);
    nu += plot.position - fused_plot.position;
    S += plot.covariance - fused_plot.covariance;
  } else if (b.correlated) {
    nu(1) /= b.alpha;
    S.row(1) /= b.alpha;
    S.col(1) /= b.alpha;
  } else {
    nu(1) = wrap_angle(nu(1) + wrap_angle(azimuth - chosen));
  }
}

// One scan of one block's W tracks (bank::BlockStep: the plots' range and azimuth).
template <int W>
[[gnu::flatten]] IMM_VECTOR_CLONES void step_block(const double (&p)[2][2],
                                                   const wimm::Constants& b,
                                                   const bank::BlockStep& block) {
  auto st = [&](int entry) { return block.slot(entry); };
  const double* range = block.z0;
  const double* azimuth = block.z1;
  // 1. The mixing and both modes' predictions, and their predicted ranges and azimuths.
  Predicted<W> m;  // NOLINT(cppcoreguidelines-pro-type-member-init): written first
  predict_block<W>(p, b, st, m);
  const auto& predicted = m.mixing.predicted;
  auto& cv = m.cv;
  auto& singer = m.singer;
  auto& px = m.px;
  auto& py = m.py;
  auto& r = m.r;
  auto& predicted_azimuth = m.predicted_azimuth;

  // 2. θ̄, the choice and the modes' linearizations (wimm_step.hpp, as the one-track filter's).
  double theta_bar[W];
  wimm::theta_bar<W>(predicted, px, py, r, theta_bar);
  // One lane at a time: the wraps (exact remainders) and the converted plot's sin and cos.
  bank::Linearization<W> lin[2];
  double fused[W], chosen[W];
  for (int l = 0; l < W; ++l) {
    const wimm::Choice choice = wimm::choose(b, predicted[0][l], azimuth[l], theta_bar[l]);
    fused[l] = choice.fuse ? 1.0 : 0.0;
    chosen[l] = choice.azimuth;
    if (b.converted) {
      const CartesianPlot plot = wimm::converted_plot(b, range[l], choice.azimuth);
      for (int j = 0; j < 2; ++j) wimm::converted_lane<W>(plot, px[j][l], py[j][l], lin[j], l);
      continue;
    }
    for (int j = 0; j < 2; ++j) {
      wimm::polar_lane<W>(b, choice.fuse, range[l], choice.azimuth, theta_bar[l], px[j][l],
                          py[j][l], r[j][l], predicted_azimuth[j][l], lin[j], l);
    }
  }

  // 3. The updates, the posterior μ and the commit.
  bank::update_mode<kCvAxis, W>(lin[0], cv);
  bank::update_mode<kSingerAxis, W>(lin[1], singer);
  double commit[W];
  bank::finish_and_keep<kCvAxis, kSingerAxis, W>(
      m.mixing, kModes, kLogMu, cv, singer, block,
      [&](int l, Eigen::Vector2d& nu, Eigen::Matrix2d& S) {
        to_plot(b, fused[l] != 0.0, range[l], azimuth[l], chosen[l], nu, S);
      },
      commit);
  bank::keep<W>(st, kFused, fused, commit);
}

// The gating matrix of one block's tracks (`g`) (an nIMM: no fusion, the extended update): the
// mixing and both predictions once, then per plot both modes' polar linearizations and updates,
// which are not kept, and each track's answer into g's columns.
template <int W>
[[gnu::flatten]] IMM_VECTOR_CLONES void score_block(const double (&p)[2][2],
                                                    const wimm::Constants& b,
                                                    const bank::GatingBlock& g) {
  auto st = [&](int entry) { return g.slot(entry); };
  Predicted<W> m;  // NOLINT(cppcoreguidelines-pro-type-member-init): written first
  predict_block<W>(p, b, st, m);
  bank::score_plots<kCvAxis, kSingerAxis, W>(
      m.mixing, m.cv, m.singer, g, [&](const Eigen::Vector2d& z, bank::Linearization<W>(&lin)[2]) {
        for (int l = 0; l < W; ++l) {
          for (int j = 0; j < 2; ++j) {
            wimm::polar_lane<W>(b, false, z(0), z(1), 0.0, m.px[j][l], m.py[j][l], m.r[j][l],
                                m.predicted_azimuth[j][l], lin[j], l);
          }
        }
      });
}

}  // namespace

// The kernel's constants, made once per bank.
struct WimmTrackBank::Constants {
  double p[2][2] = {};  // Π
  wimm::Constants b;
};

WimmTrackBank::WimmTrackBank(const WimmSpec& spec, std::size_t capacity)
    : TwoModeLaneStorage("WimmTrackBank", {kCv.d, kCv.mean, kCv.covariance},
                         {kSinger.d, kSinger.mean, kSinger.covariance}, kLogMu),
      spec_(spec) {
  spec.validate();
  bank::require_positive_transitions(spec.transition);
  allocate(capacity, 1, kBlock, kSlots);
  auto constants = std::make_shared<Constants>();
  bank::transitions_into(spec.transition, constants->p);
  constants->b = wimm::constants_of(spec);
  constants_ = std::move(constants);
}

void WimmTrackBank::initialize(std::size_t track, const GaussianState<6>& state) {
  const std::ptrdiff_t t = start(track, state, spec_.initial_probabilities);
  slot(kFused)[t] = 0.0;
  mark_initialized(t);
}

void WimmTrackBank::step_lanes(const LaneStep& call) {
  // Lanes past the last track get a plot 1 away from the radar (their results are not kept).
  bank::step_blocks<kBlock>(call.plots, call.status, Eigen::Vector2d(1.0, 0.0), slot(0), stride(),
                            call.nis, [&](const bank::BlockStep& block) {
                              step_block<kBlock>(constants_->p, constants_->b, block);
                            });
}

bool WimmTrackBank::fused(std::size_t track) const { return slot(kFused)[checked(track)] != 0.0; }

void WimmTrackBank::score_lanes(const LaneScore& call) {
  if (spec_.fusion != FusionVariant::kNone || spec_.update != MeasurementUpdate::kExtended) {
    throw std::logic_error(
        "WimmTrackBank::candidate_log_likelihoods: a wIMM that fuses the azimuth or converts the "
        "plot does not score candidate plots (it chooses its measurement from the prediction and "
        "the plot together: WimmFilter::has_split_cycle is false)");
  }
  bank::score_in_blocks<kBlock>(call.plots, call.gate, call.gate_scale, slot(0), stride(), call.out,
                                [&](const bank::GatingBlock& block) {
                                  score_block<kBlock>(constants_->p, constants_->b, block);
                                });
}

}  // namespace imm
