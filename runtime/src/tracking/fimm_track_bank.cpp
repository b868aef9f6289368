// SPDX-License-Identifier: Apache-2.0
// The FIMM's bank: tracks as lanes, blocks of kBlock tracks (see the header). The order of
// operations follows FimmFilter::step through ImmEstimator::step, KalmanMode::propose and
// iterated_update (update for one iteration), with TskSensorMeasurement's h, Jacobian and R.
#include "imm/tracking/fimm_track_bank.hpp"

#include <array>
#include <cmath>
#include <utility>

#include "bank_checks.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/estimation/kalman_filter.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm/models/motion/constant_acceleration.hpp"
#include "two_mode_lanes.hpp"

namespace imm {
namespace {

// Both modes are CA: 3 states per axis, the mixing space's own.
constexpr int kAxis = 3;
// State slots per track: each mode's mean [ξ, ξ̇, ξ̈, η, η̇, η̈] and its covariance's upper
// triangle (row by row), then log μ (cruise, lane change).
constexpr std::array<bank::ModeSlots, 2> kModes{bank::ModeSlots{kAxis, 0, 6},
                                                bank::ModeSlots{kAxis, 27, 33}};
constexpr int kLogMu = 54, kSlots = 56;

struct BankConstants {
  double p[2][2] = {};  // Π
  std::array<bank::AxisModel, 2> modes;
  double r00 = 0.0, r01 = 0.0, r11 = 0.0;  // R, with the sensor model's own noise
  const TskSensorModel* sensor = nullptr;  // null: h = identity
  int iterations = 1;
};

template <int W>
using Mode = bank::ModeLanes<kAxis, W>;

// The linearization of every lane still iterating (`active`) at `point`: H = ∇h there and the
// innovation z − h(point) − H (x⁻ − point) (iterated_update; the last term is 0 at x⁻, the EKF).
// One lane at a time: the TSK sensor model is scalar code.
template <int W>
[[gnu::always_inline]] inline void linearize(const BankConstants& b, const double* z0,
                                             const double* z1, const Mode<W>& mode,
                                             const double (&point)[6][W], const double* active,
                                             bank::Linearization<W>& g) {
  for (int l = 0; l < W; ++l) {
    g.r00[l] = b.r00;
    g.r01[l] = b.r01;
    g.r11[l] = b.r11;
    bool finite = true;
    for (int a = 0; a < 6; ++a) finite = finite && std::isfinite(point[a][l]);
    g.defined[l] = finite ? 1.0 : 0.0;
    double h0 = point[0][l], h1 = point[kAxis][l];
    double H[2][2] = {{1.0, 0.0}, {0.0, 1.0}};
    if (b.sensor != nullptr && finite && active[l] != 0.0) {
      const TskEvaluation e = b.sensor->evaluate(Eigen::Vector2d(point[0][l], point[kAxis][l]));
      h0 = e.value(0);
      h1 = e.value(1);
      for (int m = 0; m < 2; ++m) {
        for (int c = 0; c < 2; ++c) H[m][c] = e.jacobian(m, c);
      }
    }
    const double d0 = mode.x[0][l] - point[0][l], d1 = mode.x[kAxis][l] - point[kAxis][l];
    for (int m = 0; m < 2; ++m) {
      for (int c = 0; c < 2; ++c) g.h[m][c][l] = H[m][c];
    }
    g.nu0[l] = (z0[l] - h0) - (H[0][0] * d0 + H[0][1] * d1);
    g.nu1[l] = (z1[l] - h1) - (H[1][0] * d0 + H[1][1] * d1);
  }
}

// A mode's update (KalmanMode::propose): the EKF, or the iterated EKF lane by lane — a lane stops
// at a failed update (its status stands) or once its step, relative to the prior's standard
// deviations, is below the tolerance, and keeps that iteration's result.
template <int W>
[[gnu::always_inline]] inline void update(const BankConstants& b, const double* z0,
                                          const double* z1, Mode<W>& mode) {
  double point[6][W], active[W];
  for (int a = 0; a < 6; ++a) IMM_LANES point[a][l] = mode.x[a][l];
  IMM_LANES active[l] = 1.0;
  bank::Linearization<W> g;  // NOLINT(cppcoreguidelines-pro-type-member-init): written first
  const int iterations = b.sensor != nullptr ? b.iterations : 1;
  if (iterations <= 1) {
    linearize<W>(b, z0, z1, mode, point, active, g);
    bank::update_mode<kAxis, W>(g, mode);
    return;
  }
  double scale[6][W];
  for (int a = 0; a < 6; ++a) {
    IMM_LANES {
      const double s = std::sqrt(mode.P[a][a][l]);
      scale[a][l] = pick(s > 1e-300, s, 1e-300);
    }
  }
  double xu[6][W] = {}, U[6][6][W] = {}, log_likelihood[W] = {}, code[W] = {};
  for (int i = 0; i < iterations; ++i) {
    linearize<W>(b, z0, z1, mode, point, active, g);
    bank::update_mode<kAxis, W>(g, mode);
    double take[W], running = 0.0;
    IMM_LANES {
      double step = 0.0;
      for (int a = 0; a < 6; ++a) {
        const double s = std::abs(mode.xu[a][l] - point[a][l]) / scale[a][l];
        step = pick(s > step, s, step);
      }
      take[l] = active[l];
      const bool taken = take[l] != 0.0;
      log_likelihood[l] = pick(taken, mode.log_likelihood[l], log_likelihood[l]);
      code[l] = pick(taken, mode.code[l], code[l]);
      active[l] =
          pick(taken & (mode.code[l] == bank::kOk) & !(step < kIteratedUpdateTolerance), 1.0, 0.0);
      running += active[l];
    }
    for (int a = 0; a < 6; ++a) {
      IMM_LANES {
        xu[a][l] = pick(take[l] != 0.0, mode.xu[a][l], xu[a][l]);
        point[a][l] = xu[a][l];
      }
      for (int c = 0; c < 6; ++c) {
        IMM_LANES U[a][c][l] = pick(take[l] != 0.0, mode.U[a][c][l], U[a][c][l]);
      }
    }
    if (running == 0.0) break;
  }
  for (int a = 0; a < 6; ++a) {
    IMM_LANES mode.xu[a][l] = xu[a][l];
    for (int c = 0; c < 6; ++c) IMM_LANES mode.U[a][c][l] = U[a][c][l];
  }
  IMM_LANES {
    mode.log_likelihood[l] = log_likelihood[l];
    mode.code[l] = code[l];
  }
}

// One scan of one block's W tracks. `state` points at the block's first track of slot 0; `z0`
// and `z1` the plots (NaN: unusable); `stepped` 1 for a track to step; `code` receives each
// track's outcome.
template <int W>
[[gnu::flatten]] IMM_VECTOR_CLONES void step_block(const BankConstants& b, double* state,
                                                   std::ptrdiff_t stride, const double* z0,
                                                   const double* z1, const double* stepped,
                                                   double* code) {
  auto st = [&](int entry) { return state + entry * stride; };
  bank::Mixing<W> mixing;  // NOLINT(cppcoreguidelines-pro-type-member-init): written first
  double embedded[2][6][W], covariance[2][6][6][W];
  bank::load_and_weigh<W>(b.p, kModes, kLogMu, st, mixing, embedded, covariance);
  Mode<W> modes[2];
  for (int j = 0; j < 2; ++j) {
    bank::mix_and_predict<kAxis, W>(b.modes[static_cast<std::size_t>(j)], mixing.weight[0][j],
                                    mixing.weight[1][j], embedded, covariance, modes[j]);
    update<W>(b, z0, z1, modes[j]);
  }
  double usable[W], commit[W], log_mu[2][W];
  IMM_LANES usable[l] = pick((z0[l] == z0[l]) & (z1[l] == z1[l]), 1.0, 0.0);
  bank::finish<kAxis, kAxis, W>(mixing, modes[0], modes[1], usable, stepped, log_mu, code, commit);
  bank::keep<W>(st, kLogMu, log_mu[0], commit);
  bank::keep<W>(st, kLogMu + 1, log_mu[1], commit);
  for (int j = 0; j < 2; ++j) {
    bank::keep_mode<kAxis, W>(st, kModes[static_cast<std::size_t>(j)], modes[j], commit);
  }
}

}  // namespace

FimmTrackBank::FimmTrackBank(const FimmSpec& spec, std::shared_ptr<const TskSensorModel> sensor,
                             std::size_t capacity)
    : spec_(spec), sensor_(std::move(sensor)) {
  spec.validate();
  bank::require_positive_transitions(spec.transition);
  bank::require_capacity(capacity);
  capacity_ = capacity;
  stride_ = static_cast<std::ptrdiff_t>((capacity + kBlock - 1) / kBlock * kBlock);
  state_.assign(static_cast<std::size_t>(kSlots * stride_), 0.0);
  initialized_.assign(capacity, 0);
}

std::size_t FimmTrackBank::checked(std::size_t track) const {
  return bank::checked_track(track, capacity_);
}

bool FimmTrackBank::initialized(std::size_t track) const {
  return initialized_[checked(track)] != 0;
}

void FimmTrackBank::initialize(std::size_t track, const GaussianState<6>& state) {
  const auto t = static_cast<std::ptrdiff_t>(checked(track));
  if (!state.all_finite()) throw InvalidParameter("state", "must be finite");
  auto at = [&](int entry) { return slot(entry); };
  for (const bank::ModeSlots& mode : kModes) bank::start_mode(at, mode, t, state);
  for (int j = 0; j < 2; ++j) slot(kLogMu + j)[t] = safe_log(spec_.initial_probabilities(j));
  initialized_[static_cast<std::size_t>(t)] = 1;
}

void FimmTrackBank::step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status) {
  bank::check_step("FimmTrackBank", plots.size(), status.size(), initialized_);
  BankConstants b{};
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < 2; ++j) b.p[i][j] = spec_.transition(i, j);
  }
  for (int j = 0; j < 2; ++j) {
    b.modes[static_cast<std::size_t>(j)] = bank::axis_model<kAxis>(
        constant_acceleration<1>(spec_.sample_period, spec_.process_noise(j)));
  }
  Eigen::Matrix2d R = spec_.measurement_covariance;
  if (sensor_) R += sensor_->noise_covariance();
  b.r00 = R(0, 0);
  b.r01 = R(0, 1);
  b.r11 = R(1, 1);
  b.sensor = sensor_.get();
  b.iterations = spec_.iterations;
  bank::step_blocks<kBlock>(plots, status, Eigen::Vector2d::Zero(),
                            [&](std::size_t first, const double* z0, const double* z1,
                                const double* stepped, double* code) {
                              step_block<kBlock>(b, state_.data() + first, stride_, z0, z1, stepped,
                                                 code);
                            });
}

GaussianState<6> FimmTrackBank::estimate(std::size_t track) const {
  const auto t = static_cast<std::ptrdiff_t>(checked(track));
  return bank::combined_estimate([&](int entry) { return slot(entry); }, kModes, kLogMu, t);
}

ModeVector FimmTrackBank::mode_probabilities(std::size_t track) const {
  const auto t = static_cast<std::ptrdiff_t>(checked(track));
  ModeVector mu(2);
  for (int j = 0; j < 2; ++j) mu(j) = std::exp(slot(kLogMu + j)[t]);
  return mu;
}

}  // namespace imm
