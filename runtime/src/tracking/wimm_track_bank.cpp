// SPDX-License-Identifier: Apache-2.0
// The weighted IMM's bank: tracks as lanes, blocks of kBlock tracks stepped in three phases (see
// the header). The order of operations follows WimmFilter::step through ImmEstimator::step_with,
// KalmanMode::propose and update_with_innovation.
#include "imm/tracking/wimm_track_bank.hpp"

#include <array>
#include <cmath>
#include <limits>

#include "bank_checks.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/math/angle.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm/models/measurement/polar_measurement.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/models/motion/singer.hpp"
#include "two_mode_lanes.hpp"

namespace imm {
namespace {

// States per axis of the CV and the Singer mode; the mixing space has 3 ([p, v, a] per axis).
constexpr int kCvAxis = 2, kSingerAxis = 3;
// State slots per track: the CV mode's mean [x, vx, y, vy] and its covariance's upper triangle
// (row by row), the Singer mode's mean [x, vx, ax, y, vy, ay] and upper triangle, log μ (CV,
// Singer), and whether the last step fused.
constexpr bank::ModeSlots kCv{kCvAxis, 0, 4}, kSinger{kSingerAxis, 14, 20};
constexpr std::array<bank::ModeSlots, 2> kModes{kCv, kSinger};
constexpr int kLogMu = 41, kFused = 43, kSlots = 44;

struct BankConstants {
  double p[2][2] = {};  // Π
  bank::AxisModel cv, singer;
  double range_variance = 0.0, azimuth_variance = 0.0, threshold = 0.0, alpha = 1.0;
  bool fuse = false, correlated = false, converted = false;
};

// One scan of one block's W tracks. `state` points at the block's first track of slot 0; `range`
// and `azimuth` the plots (NaN: unusable); `stepped` 1 for a track to step; `code` receives each
// track's outcome.
template <int W>
[[gnu::flatten]] IMM_VECTOR_CLONES void step_block(const BankConstants& b, double* state,
                                                   std::ptrdiff_t stride, const double* range,
                                                   const double* azimuth, const double* stepped,
                                                   double* code) {
  auto st = [&](int entry) { return state + entry * stride; };
  // 1. The mixing and both modes' predictions.
  bank::Mixing<W> mixing;  // NOLINT(cppcoreguidelines-pro-type-member-init): written first
  double embedded[2][6][W], covariance[2][6][6][W];
  bank::load_and_weigh<W>(b.p, kModes, kLogMu, st, mixing, embedded, covariance);
  // Every field is written before it is read; zeroing them first would cost.
  bank::ModeLanes<kCvAxis, W> cv;          // NOLINT(cppcoreguidelines-pro-type-member-init)
  bank::ModeLanes<kSingerAxis, W> singer;  // NOLINT(cppcoreguidelines-pro-type-member-init)
  const auto& weight = mixing.weight;
  const auto& predicted = mixing.predicted;
  bank::mix_and_predict<kCvAxis, W>(b.cv, weight[0][0], weight[1][0], embedded, covariance, cv);
  bank::mix_and_predict<kSingerAxis, W>(b.singer, weight[0][1], weight[1][1], embedded, covariance,
                                        singer);

  // 2. The predicted ranges and azimuths, and θ̄: the μ̄-weighted circular mean of the azimuths
  // (WimmFilter::step, eq. 9–11, with sin θ_j = x_j / r_j and cos θ_j = y_j / r_j), over lanes.
  double px[2][W], py[2][W], r[2][W], predicted_azimuth[2][W], theta_bar[W];
  for (int j = 0; j < 2; ++j) {
    const double* x = j == 0 ? cv.x[0] : singer.x[0];
    const double* y = j == 0 ? cv.x[kCvAxis] : singer.x[kSingerAxis];
    IMM_LANES {
      px[j][l] = x[l];
      py[j][l] = y[l];
      r[j][l] = std::sqrt(x[l] * x[l] + y[l] * y[l]);
      predicted_azimuth[j][l] = lane_atan2(x[l], y[l]);
    }
  }
  IMM_LANES {
    double s = 0.0, c = 0.0;
    for (int j = 0; j < 2; ++j) {
      s += predicted[j][l] * (px[j][l] / r[j][l]);
      c += predicted[j][l] * (py[j][l] / r[j][l]);
    }
    theta_bar[l] = lane_atan2(s, c);
  }
  // The fusion and the modes' linearizations (FusedPolarMeasurement), one lane at a time: the
  // wraps (exact remainders) and, for the converted update, libm's sin and cos.
  bank::Linearization<W> lin[2];
  double fused[W];
  for (int l = 0; l < W; ++l) {
    const bool fuse = b.fuse && predicted[0][l] > b.threshold;
    const double chosen = fuse ? blend_angles(azimuth[l], theta_bar[l], b.alpha) : azimuth[l];
    fused[l] = fuse ? 1.0 : 0.0;
    const bool correlated = fuse && b.correlated;
    CartesianPlot plot{};
    if (b.converted) {
      plot = polar_to_cartesian(Vector<2>(range[l], chosen),
                                Vector<2>(b.range_variance, b.azimuth_variance).asDiagonal());
    }
    for (int j = 0; j < 2; ++j) {
      bank::Linearization<W>& g = lin[j];
      if (b.converted) {
        // The plot as a Cartesian position: H selects it, R = J R Jᵀ.
        g.h[0][0][l] = g.h[1][1][l] = 1.0;
        g.h[0][1][l] = g.h[1][0][l] = 0.0;
        g.r00[l] = plot.covariance(0, 0);
        g.r01[l] = plot.covariance(0, 1);
        g.r11[l] = plot.covariance(1, 1);
        g.nu0[l] = plot.position(0) - px[j][l];
        g.nu1[l] = plot.position(1) - py[j][l];
        g.defined[l] = 1.0;
        continue;
      }
      const double x = px[j][l], y = py[j][l];
      const double r2 = x * x + y * y;
      const double a = correlated ? b.alpha : 1.0;
      g.h[0][0][l] = x / r[j][l];
      g.h[0][1][l] = y / r[j][l];
      g.h[1][0][l] = correlated ? y / r2 * a : y / r2;
      g.h[1][1][l] = correlated ? -x / r2 * a : -x / r2;
      g.r00[l] = b.range_variance;
      g.r01[l] = 0.0;
      g.r11[l] = correlated ? b.azimuth_variance * a * a : b.azimuth_variance;
      const double h_azimuth =
          correlated ? theta_bar[l] + a * wrap_angle(predicted_azimuth[j][l] - theta_bar[l])
                     : predicted_azimuth[j][l];
      g.nu0[l] = range[l] - r[j][l];
      g.nu1[l] = wrap_angle(chosen - h_azimuth);
      g.defined[l] = r[j][l] > PolarMeasurement<6>::kMinimumRange ? 1.0 : 0.0;
    }
  }

  // 3. The updates, the posterior μ and the commit.
  bank::update_mode<kCvAxis, W>(lin[0], cv);
  bank::update_mode<kSingerAxis, W>(lin[1], singer);
  double usable[W], commit[W], log_mu[2][W];
  IMM_LANES usable[l] = pick((range[l] == range[l]) & (azimuth[l] == azimuth[l]), 1.0, 0.0);
  bank::finish<kCvAxis, kSingerAxis, W>(mixing, cv, singer, usable, stepped, log_mu, code, commit);
  bank::keep<W>(st, kLogMu, log_mu[0], commit);
  bank::keep<W>(st, kLogMu + 1, log_mu[1], commit);
  bank::keep<W>(st, kFused, fused, commit);
  bank::keep_mode<kCvAxis, W>(st, kCv, cv, commit);
  bank::keep_mode<kSingerAxis, W>(st, kSinger, singer, commit);
}

// The kernel's constants of a spec.
BankConstants constants_of(const WimmSpec& spec) {
  BankConstants b;
  bank::transitions_into(spec.transition, b.p);
  b.cv = bank::axis_model<kCvAxis>(constant_velocity<1>(spec.sample_period, spec.cv_process_noise));
  b.singer = bank::axis_model<kSingerAxis>(
      singer<1>(spec.sample_period, spec.singer_tau, spec.singer_sigma));
  b.range_variance = spec.range_sigma * spec.range_sigma;
  b.azimuth_variance = spec.azimuth_sigma * spec.azimuth_sigma;
  b.threshold = spec.threshold;
  b.alpha = spec.alpha;
  b.fuse = spec.fusion != FusionVariant::kNone;
  b.correlated = spec.fusion == FusionVariant::kCorrelated;
  b.converted = spec.update == MeasurementUpdate::kConverted;
  return b;
}

}  // namespace

// The kernel's constants, made once per bank.
struct WimmTrackBank::Constants {
  BankConstants b;
};

WimmTrackBank::WimmTrackBank(const WimmSpec& spec, std::size_t capacity) : spec_(spec) {
  spec.validate();
  bank::require_positive_transitions(spec.transition);
  allocate(capacity, 1, kBlock, kSlots);
  constants_ = std::make_shared<const Constants>(Constants{constants_of(spec)});
}

void WimmTrackBank::initialize(std::size_t track, const GaussianState<6>& state) {
  const std::ptrdiff_t t = checked(track);
  bank::start_track([&](int entry) { return slot(entry); }, kModes, kLogMu, t, state,
                    spec_.initial_probabilities);
  slot(kFused)[t] = 0.0;
  mark_initialized(t);
}

void WimmTrackBank::step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status) {
  check_step("WimmTrackBank", plots.size(), status.size());
  // Lanes past the last track get a plot 1 away from the radar (their results are not kept).
  bank::step_blocks<kBlock>(plots, status, Eigen::Vector2d(1.0, 0.0),
                            [&](std::size_t first, const double* range, const double* azimuth,
                                const double* stepped, double* code) {
                              step_block<kBlock>(constants_->b, slot(0) + first, stride(), range,
                                                 azimuth, stepped, code);
                            });
}

GaussianState<6> WimmTrackBank::estimate(std::size_t track) const {
  const std::ptrdiff_t t = checked(track);
  return bank::combined_estimate([&](int entry) { return slot(entry); }, kModes, kLogMu, t);
}

ModeVector WimmTrackBank::mode_probabilities(std::size_t track) const {
  return bank::mode_probabilities([&](int entry) { return slot(entry); }, kLogMu, checked(track));
}

bool WimmTrackBank::fused(std::size_t track) const { return slot(kFused)[checked(track)] != 0.0; }

}  // namespace imm
