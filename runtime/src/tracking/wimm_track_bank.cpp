// SPDX-License-Identifier: Apache-2.0
// The weighted IMM's bank: tracks as lanes, blocks of kBlock tracks stepped in three phases (see
// the header). The order of operations follows WimmFilter::step through ImmEstimator::step_with,
// KalmanMode::propose and update_with_innovation.
#include "imm/tracking/wimm_track_bank.hpp"

#include <array>
#include <cmath>
#include <limits>

#include "axis_lane_bank.hpp"
#include "bank_checks.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/math/angle.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm/models/measurement/polar_measurement.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/models/motion/singer.hpp"

namespace imm {
namespace {

// States per axis of the CV and the Singer mode; the mixing space has 3 ([p, v, a] per axis).
constexpr int kCvAxis = 2, kSingerAxis = 3;
// State slots per track: the CV mode's mean [x, vx, y, vy] and its covariance's upper triangle
// (row by row), the Singer mode's mean [x, vx, ax, y, vy, ay] and upper triangle, log μ (CV,
// Singer), and whether the last step fused.
constexpr int kCvMean = 0, kCvCov = 4, kSingerMean = 14, kSingerCov = 20, kLogMu = 41, kFused = 43,
              kSlots = 44;
using bank::kBadPlot, bank::kNonFinite, bank::kOk, bank::kSingular, bank::kUndefined,
    bank::kUnderflow;

// Entry (i, j), i ≤ j, of an n × n upper triangle stored row by row.
constexpr int packed(int n, int i, int j) { return i * n - i * (i - 1) / 2 + (j - i); }
// The mixing-space index of state i of a mode with d states per axis.
constexpr int mixing_index(int d, int i) { return (i / d) * 3 + i % d; }

// One axis block of a mode's F and Q (the first d × d entries used).
struct AxisModel {
  double F[3][3] = {};
  double Q[3][3] = {};
};

struct BankConstants {
  double p[2][2];  // Π
  AxisModel cv, singer;
  double range_variance, azimuth_variance, threshold, alpha;
  bool fuse, correlated, converted;
};

template <int D>
AxisModel axis_model(const LinearMotionModel<D>& model) {
  AxisModel axis;
  for (int i = 0; i < D; ++i) {
    for (int j = 0; j < D; ++j) {
      axis.F[i][j] = model.transition(i, j);
      axis.Q[i][j] = model.process_noise(i, j);
    }
  }
  return axis;
}

// One mode of a block: its mixed then predicted then updated mean and covariance.
template <int D, int W>
struct ModeLanes {
  static constexpr int N = 2 * D;
  double x[N][W];     // mixed mean, then predicted, then updated
  double P[N][N][W];  // mixed covariance, then predicted
  double U[N][N][W];  // updated covariance
  double log_likelihood[W], code[W];
};

// A mode's linearization at its prediction: H's two columns at the position (x, y), R, ν, and
// whether h is defined there.
template <int W>
struct Linearization {
  double h[2][2][W];
  double r00[W], r01[W], r11[W], nu0[W], nu1[W], defined[W];
};

// Mode j's mixed initial condition (eq. 4–6 of seed 000, in the 6-state space, the CV mode
// zero-padded) in its own states, and its prediction (KalmanMode::propose). Every statement is a
// loop over the lanes, which is what the compiler vectorizes.
template <int D, int W>
[[gnu::always_inline]] inline void mix_and_predict(const AxisModel& model, const double* weight0,
                                                   const double* weight1,
                                                   const double (&embedded)[2][6][W],
                                                   const double (&covariance)[2][6][6][W],
                                                   ModeLanes<D, W>& mode) {
  constexpr int N = 2 * D;
  double mean[N][W], d[2][N][W], mixed[N][N][W];
  for (int i = 0; i < N; ++i) {
    const int a = mixing_index(D, i);
    IMM_LANES {
      mean[i][l] = 0.0 + weight0[l] * embedded[0][a][l] + weight1[l] * embedded[1][a][l];
      d[0][i][l] = embedded[0][a][l] - mean[i][l];
      d[1][i][l] = embedded[1][a][l] - mean[i][l];
    }
  }
  // Σ_m w_m (P_m + d_m d_mᵀ), a weight of 0 adding nothing (ImmEstimator::moment_match); the
  // terms of (i, k) and (k, i) are the same products, so the result is exactly symmetric.
  for (int i = 0; i < N; ++i) {
    for (int k = i; k < N; ++k) {
      const int a = mixing_index(D, i), b = mixing_index(D, k);
      IMM_LANES {
        const double t0 = weight0[l] * (covariance[0][a][b][l] + d[0][i][l] * d[0][k][l]);
        const double t1 = weight1[l] * (covariance[1][a][b][l] + d[1][i][l] * d[1][k][l]);
        mixed[i][k][l] = mixed[k][i][l] =
            (0.0 + pick(weight0[l] != 0.0, t0, 0.0)) + pick(weight1[l] != 0.0, t1, 0.0);
      }
    }
  }
  // x⁻ = F x, P⁻ = F P Fᵀ + Q per axis block (F and Q are block-diagonal), symmetrized.
  for (int i = 0; i < N; ++i) {
    const int axis = i / D, r = i % D;
    IMM_LANES {
      double sum = 0.0;
      for (int c = 0; c < D; ++c) sum += model.F[r][c] * mean[axis * D + c][l];
      mode.x[i][l] = sum;
    }
  }
  double fp[N][N][W];
  for (int i = 0; i < N; ++i) {
    for (int k = 0; k < N; ++k) {
      const int axis = i / D, r = i % D;
      IMM_LANES {
        double sum = 0.0;
        for (int c = 0; c < D; ++c) sum += model.F[r][c] * mixed[axis * D + c][k][l];
        fp[i][k][l] = sum;
      }
    }
  }
  double predicted[N][N][W];
  for (int i = 0; i < N; ++i) {
    for (int k = 0; k < N; ++k) {
      const int axis = k / D, r = k % D;
      const double q = i / D == axis ? model.Q[i % D][r] : 0.0;
      IMM_LANES {
        double sum = 0.0;
        for (int c = 0; c < D; ++c) sum += fp[i][axis * D + c][l] * model.F[r][c];
        predicted[i][k][l] = sum + q;
      }
    }
  }
  for (int i = 0; i < N; ++i) {
    IMM_LANES mode.P[i][i][l] = predicted[i][i][l];
    for (int k = i + 1; k < N; ++k) {
      IMM_LANES mode.P[i][k][l] = mode.P[k][i][l] = 0.5 * (predicted[i][k][l] + predicted[k][i][l]);
    }
  }
}

// The Joseph-form update of one mode with its linearization (update_with_innovation with H's
// non-zero columns 0 and D), its log-likelihood and outcome code.
template <int D, int W>
[[gnu::always_inline]] inline void update_mode(const Linearization<W>& g, ModeLanes<D, W>& mode) {
  constexpr int N = 2 * D;
  const auto& h = g.h;
  double pht[N][2][W];
  for (int a = 0; a < N; ++a) {
    for (int m = 0; m < 2; ++m) {
      IMM_LANES pht[a][m][l] = mode.P[a][0][l] * h[m][0][l] + mode.P[a][D][l] * h[m][1][l];
    }
  }
  double si[2][2][W], log_det[W], valid[W];
  IMM_LANES {
    const double s00 = (h[0][0][l] * pht[0][0][l] + h[0][1][l] * pht[D][0][l]) + g.r00[l];
    const double s01 = (h[0][0][l] * pht[0][1][l] + h[0][1][l] * pht[D][1][l]) + g.r01[l];
    const double s10 = (h[1][0][l] * pht[0][0][l] + h[1][1][l] * pht[D][0][l]) + g.r01[l];
    const double s11 = (h[1][0][l] * pht[0][1][l] + h[1][1][l] * pht[D][1][l]) + g.r11[l];
    const double S[2][2] = {{s00, 0.5 * (s01 + s10)}, {0.5 * (s01 + s10), s11}};
    const bool finite = std::isfinite(S[0][0] + S[0][1] + S[1][1]);
    const double det = S[0][0] * S[1][1] - S[0][1] * S[1][0];
    valid[l] = pick(finite & (S[0][0] > 0.0) & (det > 1e-14 * S[0][0] * S[1][1]), 1.0, 0.0);
    log_det[l] = lane_log(det);
    // S⁻¹ in closed form (as Eigen's 2 × 2 inverse), symmetrized.
    const double inverse_det = 1.0 / (S[0][0] * S[1][1] - S[1][0] * S[0][1]);
    si[0][0][l] = S[1][1] * inverse_det;
    si[0][1][l] = si[1][0][l] = 0.5 * (-S[0][1] * inverse_det + -S[1][0] * inverse_det);
    si[1][1][l] = S[0][0] * inverse_det;
  }
  double K[N][2][W];
  for (int a = 0; a < N; ++a) {
    for (int m = 0; m < 2; ++m) {
      IMM_LANES K[a][m][l] = pht[a][0][l] * si[0][m][l] + pht[a][1][l] * si[1][m][l];
    }
  }
  // C = P − K (P Hᵀ)ᵀ, C Hᵀ, K R; then P⁺ = C − (C Hᵀ) Kᵀ + (K R) Kᵀ.
  double C[N][N][W];
  for (int a = 0; a < N; ++a) {
    for (int b = 0; b < N; ++b) {
      IMM_LANES C[a][b][l] =
          mode.P[a][b][l] - (K[a][0][l] * pht[b][0][l] + K[a][1][l] * pht[b][1][l]);
    }
  }
  double cht[N][2][W], kr[N][2][W];
  for (int a = 0; a < N; ++a) {
    for (int m = 0; m < 2; ++m) {
      IMM_LANES {
        const double r0 = m == 0 ? g.r00[l] : g.r01[l], r1 = m == 0 ? g.r01[l] : g.r11[l];
        cht[a][m][l] = C[a][0][l] * h[m][0][l] + C[a][D][l] * h[m][1][l];
        kr[a][m][l] = K[a][0][l] * r0 + K[a][1][l] * r1;
      }
    }
  }
  double updated[N][N][W];
  for (int a = 0; a < N; ++a) {
    for (int b = 0; b < N; ++b) {
      IMM_LANES updated[a][b][l] =
          (C[a][b][l] - (cht[a][0][l] * K[b][0][l] + cht[a][1][l] * K[b][1][l])) +
          (kr[a][0][l] * K[b][0][l] + kr[a][1][l] * K[b][1][l]);
    }
  }
  // x * 0 is 0 for a finite x and NaN otherwise: the sum is 0 exactly when every entry is finite.
  double zero[W];
  IMM_LANES zero[l] = 0.0;
  for (int a = 0; a < N; ++a) {
    IMM_LANES {
      mode.x[a][l] = mode.x[a][l] + (K[a][0][l] * g.nu0[l] + K[a][1][l] * g.nu1[l]);
      mode.U[a][a][l] = updated[a][a][l];
      zero[l] += mode.x[a][l] * 0.0 + updated[a][a][l] * 0.0;
    }
    for (int b = a + 1; b < N; ++b) {
      IMM_LANES {
        const double mean = 0.5 * (updated[a][b][l] + updated[b][a][l]);
        mode.U[a][b][l] = mode.U[b][a][l] = mean;
        zero[l] += mean * 0.0;
      }
    }
  }
  IMM_LANES {
    const double n0 = g.nu0[l], n1 = g.nu1[l];
    const double mahalanobis =
        n0 * (si[0][0][l] * n0 + si[0][1][l] * n1) + n1 * (si[1][0][l] * n0 + si[1][1][l] * n1);
    mode.log_likelihood[l] = -0.5 * (mahalanobis + log_det[l] + 2.0 * kLogTwoPi);
    mode.code[l] = pick(g.defined[l] == 0.0, kUndefined,
                        pick(valid[l] != 0.0, pick(zero[l] == 0.0, kOk, kNonFinite), kSingular));
  }
}

// One scan of one block's W tracks. `state` points at the block's first track of slot 0; `range`
// and `azimuth` the plots (NaN: unusable); `stepped` 1 for a track to step; `code` receives each
// track's outcome.
template <int W>
[[gnu::flatten]] IMM_VECTOR_CLONES void step_block(const BankConstants& b, double* state,
                                                   std::ptrdiff_t stride, const double* range,
                                                   const double* azimuth, const double* stepped,
                                                   double* code) {
  auto st = [&](int entry) { return state + entry * stride; };
  // 1. Predicted mode probabilities (ImmEstimator::predict_mode_probabilities), mixing weights
  // and the modes' current estimates in the mixing space.
  double log_c[2][W], predicted[2][W], weight[2][2][W];  // weight[i][j]: μ_ij
  double embedded[2][6][W], covariance[2][6][6][W];
  IMM_LANES {
    const double a = st(kLogMu)[l], c = st(kLogMu + 1)[l];
    const double shift = pick(c > a, c, a);
    const double scaled0 = lane_exp(a - shift), scaled1 = lane_exp(c - shift);
    const double sum0 = 0.0 + b.p[0][0] * scaled0 + b.p[1][0] * scaled1;
    const double sum1 = 0.0 + b.p[0][1] * scaled0 + b.p[1][1] * scaled1;
    log_c[0][l] = lane_log(sum0) + shift;
    log_c[1][l] = lane_log(sum1) + shift;
    predicted[0][l] = lane_exp(log_c[0][l]);
    predicted[1][l] = lane_exp(log_c[1][l]);
    weight[0][0][l] = b.p[0][0] * scaled0 / sum0;
    weight[1][0][l] = b.p[1][0] * scaled1 / sum0;
    weight[0][1][l] = b.p[0][1] * scaled0 / sum1;
    weight[1][1][l] = b.p[1][1] * scaled1 / sum1;
  }
  for (int a = 0; a < 6; ++a) {
    const bool cv_state = a % 3 != 2;
    const int i = (a / 3) * kCvAxis + a % 3;  // the CV state, where it has one
    const double* cv_mean = st(kCvMean + (cv_state ? i : 0));
    const double* singer_mean = st(kSingerMean + a);
    IMM_LANES {
      embedded[0][a][l] = cv_state ? cv_mean[l] : 0.0;
      embedded[1][a][l] = singer_mean[l];
    }
    for (int c = a; c < 6; ++c) {
      const int k = (c / 3) * kCvAxis + c % 3;
      const bool cv_entry = cv_state && c % 3 != 2;
      const double* cv_covariance = st(kCvCov + (cv_entry ? packed(4, i, k) : 0));
      const double* singer_covariance = st(kSingerCov + packed(6, a, c));
      IMM_LANES {
        covariance[0][a][c][l] = covariance[0][c][a][l] = cv_entry ? cv_covariance[l] : 0.0;
        covariance[1][a][c][l] = covariance[1][c][a][l] = singer_covariance[l];
      }
    }
  }
  ModeLanes<kCvAxis, W> cv;
  ModeLanes<kSingerAxis, W> singer;
  mix_and_predict<kCvAxis, W>(b.cv, weight[0][0], weight[1][0], embedded, covariance, cv);
  mix_and_predict<kSingerAxis, W>(b.singer, weight[0][1], weight[1][1], embedded, covariance,
                                  singer);

  // 2. The fusion and the modes' linearizations (WimmFilter::step's choice, then
  // FusedPolarMeasurement), one lane at a time: libm's hypot and atan2.
  Linearization<W> lin[2];
  double fused[W];
  for (int l = 0; l < W; ++l) {
    const double px[2] = {cv.x[0][l], singer.x[0][l]};
    const double py[2] = {cv.x[kCvAxis][l], singer.x[kSingerAxis][l]};
    double predicted_range[2], predicted_azimuth[2], r[2];
    for (int j = 0; j < 2; ++j) {
      predicted_range[j] = std::hypot(px[j], py[j]);
      predicted_azimuth[j] = azimuth_of(px[j], py[j]);
      r[j] = std::sqrt(px[j] * px[j] + py[j] * py[j]);  // the Jacobian's
    }
    double chosen = azimuth[l], theta_bar = 0.0;
    const bool fuse = b.fuse && predicted[0][l] > b.threshold;
    if (fuse) {
      // sin θ_j = x_j / r_j and cos θ_j = y_j / r_j (to rounding; an undefined mode fails anyway).
      double s = 0.0, c = 0.0;
      for (int j = 0; j < 2; ++j) {
        s += predicted[j][l] * (px[j] / r[j]);
        c += predicted[j][l] * (py[j] / r[j]);
      }
      theta_bar = std::atan2(s, c);
      chosen = blend_angles(azimuth[l], theta_bar, b.alpha);
    }
    fused[l] = fuse ? 1.0 : 0.0;
    const bool correlated = fuse && b.correlated;
    CartesianPlot plot{};
    if (b.converted) {
      plot = polar_to_cartesian(Vector<2>(range[l], chosen),
                                Vector<2>(b.range_variance, b.azimuth_variance).asDiagonal());
    }
    for (int j = 0; j < 2; ++j) {
      Linearization<W>& g = lin[j];
      if (b.converted) {
        // The plot as a Cartesian position: H selects it, R = J R Jᵀ.
        g.h[0][0][l] = g.h[1][1][l] = 1.0;
        g.h[0][1][l] = g.h[1][0][l] = 0.0;
        g.r00[l] = plot.covariance(0, 0);
        g.r01[l] = plot.covariance(0, 1);
        g.r11[l] = plot.covariance(1, 1);
        g.nu0[l] = plot.position(0) - px[j];
        g.nu1[l] = plot.position(1) - py[j];
        g.defined[l] = 1.0;
        continue;
      }
      const double x = px[j], y = py[j];
      const double r2 = x * x + y * y;
      const double a = correlated ? b.alpha : 1.0;
      g.h[0][0][l] = x / r[j];
      g.h[0][1][l] = y / r[j];
      g.h[1][0][l] = correlated ? y / r2 * a : y / r2;
      g.h[1][1][l] = correlated ? -x / r2 * a : -x / r2;
      g.r00[l] = b.range_variance;
      g.r01[l] = 0.0;
      g.r11[l] = correlated ? b.azimuth_variance * a * a : b.azimuth_variance;
      const double h_azimuth = correlated
                                   ? theta_bar + a * wrap_angle(predicted_azimuth[j] - theta_bar)
                                   : predicted_azimuth[j];
      g.nu0[l] = range[l] - predicted_range[j];
      g.nu1[l] = wrap_angle(chosen - h_azimuth);
      g.defined[l] = predicted_range[j] > PolarMeasurement<6>::kMinimumRange ? 1.0 : 0.0;
    }
  }

  // 3. The updates, the posterior μ (ImmEstimator::finish_cycle) and the commit.
  update_mode<kCvAxis, W>(lin[0], cv);
  update_mode<kSingerAxis, W>(lin[1], singer);
  double commit[W], log_mu[2][W];
  IMM_LANES {
    const double posterior0 = cv.log_likelihood[l] + log_c[0][l];
    const double posterior1 = singer.log_likelihood[l] + log_c[1][l];
    const double shift = pick(posterior1 > posterior0, posterior1, posterior0);
    const double sum = 0.0 + lane_exp(posterior0 - shift) + lane_exp(posterior1 - shift);
    const double log_sum = lane_log(sum);
    log_mu[0][l] = (posterior0 - shift) - log_sum;
    log_mu[1][l] = (posterior1 - shift) - log_sum;
    const double mode_code = pick(cv.code[l] != kOk, cv.code[l], singer.code[l]);
    const bool usable = (range[l] == range[l]) & (azimuth[l] == azimuth[l]);
    const double outcome =
        pick(mode_code != kOk, mode_code, pick(std::isfinite(shift), kOk, kUnderflow));
    code[l] = pick(usable, outcome, kBadPlot);
    commit[l] = pick((stepped[l] != 0.0) & (code[l] == kOk), 1.0, 0.0);
  }
  auto keep = [&](int entry, const double* value) {
    double* target = st(entry);
    IMM_LANES target[l] = pick(commit[l] != 0.0, value[l], target[l]);
  };
  keep(kLogMu, log_mu[0]);
  keep(kLogMu + 1, log_mu[1]);
  keep(kFused, fused);
  for (int i = 0; i < 2 * kCvAxis; ++i) {
    keep(kCvMean + i, cv.x[i]);
    for (int k = i; k < 2 * kCvAxis; ++k) keep(kCvCov + packed(4, i, k), cv.U[i][k]);
  }
  for (int i = 0; i < 2 * kSingerAxis; ++i) {
    keep(kSingerMean + i, singer.x[i]);
    for (int k = i; k < 2 * kSingerAxis; ++k) keep(kSingerCov + packed(6, i, k), singer.U[i][k]);
  }
}

}  // namespace

WimmTrackBank::WimmTrackBank(const WimmSpec& spec, std::size_t capacity) : spec_(spec) {
  spec.validate();
  if (!(spec.transition.array() > 0.0).all()) {
    throw InvalidParameter("transition", "the bank needs every transition probability > 0");
  }
  bank::require_capacity(capacity);
  capacity_ = capacity;
  stride_ = static_cast<std::ptrdiff_t>((capacity + kBlock - 1) / kBlock * kBlock);
  state_.assign(static_cast<std::size_t>(kSlots * stride_), 0.0);
  initialized_.assign(capacity, 0);
}

std::size_t WimmTrackBank::checked(std::size_t track) const {
  return bank::checked_track(track, capacity_);
}

bool WimmTrackBank::initialized(std::size_t track) const {
  return initialized_[checked(track)] != 0;
}

void WimmTrackBank::initialize(std::size_t track, const GaussianState<6>& state) {
  const auto t = static_cast<std::ptrdiff_t>(checked(track));
  if (!state.all_finite()) throw InvalidParameter("state", "must be finite");
  for (int i = 0; i < 4; ++i) {
    const int a = mixing_index(kCvAxis, i);
    slot(kCvMean + i)[t] = state.mean(a);
    for (int k = i; k < 4; ++k) {
      slot(kCvCov + packed(4, i, k))[t] = state.covariance(a, mixing_index(kCvAxis, k));
    }
  }
  for (int i = 0; i < 6; ++i) {
    slot(kSingerMean + i)[t] = state.mean(i);
    for (int k = i; k < 6; ++k) slot(kSingerCov + packed(6, i, k))[t] = state.covariance(i, k);
  }
  for (int j = 0; j < 2; ++j) slot(kLogMu + j)[t] = safe_log(spec_.initial_probabilities(j));
  slot(kFused)[t] = 0.0;
  initialized_[static_cast<std::size_t>(t)] = 1;
}

void WimmTrackBank::step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status) {
  bank::check_step("WimmTrackBank", plots.size(), status.size(), initialized_);
  BankConstants b{};
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < 2; ++j) b.p[i][j] = spec_.transition(i, j);
  }
  b.cv = axis_model<kCvAxis>(constant_velocity<1>(spec_.sample_period, spec_.cv_process_noise));
  b.singer =
      axis_model<kSingerAxis>(singer<1>(spec_.sample_period, spec_.singer_tau, spec_.singer_sigma));
  b.range_variance = spec_.range_sigma * spec_.range_sigma;
  b.azimuth_variance = spec_.azimuth_sigma * spec_.azimuth_sigma;
  b.threshold = spec_.threshold;
  b.alpha = spec_.alpha;
  b.fuse = spec_.fusion != FusionVariant::kNone;
  b.correlated = spec_.fusion == FusionVariant::kCorrelated;
  b.converted = spec_.update == MeasurementUpdate::kConverted;

  const std::size_t n = plots.size();
  constexpr auto kLanes = static_cast<std::size_t>(kBlock);
  for (std::size_t first = 0; first < n; first += kLanes) {
    double range[kBlock], azimuth[kBlock], stepped[kBlock], code[kBlock];
    for (std::size_t l = 0; l < kLanes; ++l) {
      const std::size_t track = first + l;
      const bool real = track < n;
      const bool usable = real && limits::usable_measurement(plots[track]);
      const double nan = std::numeric_limits<double>::quiet_NaN();
      range[l] = usable ? plots[track](0) : (real ? nan : 1.0);
      azimuth[l] = usable ? plots[track](1) : (real ? nan : 0.0);
      stepped[l] = real ? 1.0 : 0.0;
    }
    step_block<kBlock>(b, state_.data() + first, stride_, range, azimuth, stepped, code);
    for (std::size_t l = 0; l < kLanes && first + l < n; ++l) {
      status[first + l] = bank::status_of(code[l]);
    }
  }
}

GaussianState<6> WimmTrackBank::estimate(std::size_t track) const {
  const auto t = static_cast<std::ptrdiff_t>(checked(track));
  // The modes embedded in the 6-state space, moment-matched with μ (ImmEstimator::combine).
  std::array<Vector<6>, 2> means{};
  std::array<SquareMatrix<6>, 2> covariances{};
  for (auto& c : covariances) c.setZero();
  for (int a = 0; a < 6; ++a) {
    means[1](a) = slot(kSingerMean + a)[t];
    for (int c = a; c < 6; ++c) {
      covariances[1](a, c) = covariances[1](c, a) = slot(kSingerCov + packed(6, a, c))[t];
    }
  }
  means[0].setZero();
  for (int i = 0; i < 4; ++i) {
    const int a = mixing_index(kCvAxis, i);
    means[0](a) = slot(kCvMean + i)[t];
    for (int k = i; k < 4; ++k) {
      const int c = mixing_index(kCvAxis, k);
      covariances[0](a, c) = covariances[0](c, a) = slot(kCvCov + packed(4, i, k))[t];
    }
  }
  const ModeVector mu = mode_probabilities(track);
  GaussianState<6> out;
  out.mean = mu(0) * means[0] + mu(1) * means[1];
  out.covariance.setZero();
  for (int i = 0; i < 2; ++i) {
    if (mu(i) == 0.0) continue;
    const Vector<6> d = means[static_cast<std::size_t>(i)] - out.mean;
    out.covariance += mu(i) * (covariances[static_cast<std::size_t>(i)] + d * d.transpose());
  }
  return out;
}

ModeVector WimmTrackBank::mode_probabilities(std::size_t track) const {
  const auto t = static_cast<std::ptrdiff_t>(checked(track));
  ModeVector mu(2);
  for (int j = 0; j < 2; ++j) mu(j) = std::exp(slot(kLogMu + j)[t]);
  return mu;
}

bool WimmTrackBank::fused(std::size_t track) const {
  return slot(kFused)[static_cast<std::ptrdiff_t>(checked(track))] != 0.0;
}

}  // namespace imm
