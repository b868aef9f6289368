// SPDX-License-Identifier: Apache-2.0
#pragma once
// The Kalman step of a mode of the weighted IMM and of the FIMM, written once over W lanes: its
// own states are [x, ẋ(, ẍ), y, ẏ(, ÿ)] (D = 2 or 3 per axis) inside the 6-state mixing space
// [x, vx, ax, y, vy, ay]; F and Q are block-diagonal over the axes; the plot is measured from the
// position alone, so H is non-zero in the two position columns only. W = 1 is the one-track mode
// (PositionKalmanMode, position_kalman_mode.hpp) and W = 8 a block of a bank's tracks
// (two_mode_lanes.hpp), so a lane runs the same IEEE operations in a block as alone. Every
// statement of the lane parts is a loop over the lanes without a branch, which the compiler
// vectorizes. Not installed.

#include <cmath>

#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm/models/motion/motion_model.hpp"
#include "tracking/axis_lane_bank.hpp"

namespace imm::bank {

/// Entry (i, j), i ≤ j, of an n × n upper triangle stored row by row.
constexpr int packed(int n, int i, int j) { return i * n - i * (i - 1) / 2 + (j - i); }
/// The mixing-space index of state i of a mode with d states per axis ([p, v] or [p, v, a]).
constexpr int mixing_index(int d, int i) { return (i / d) * 3 + i % d; }

/// One axis block of a mode's F and Q (the first d × d entries used; both are block-diagonal
/// over the axes).
struct AxisModel {
  double F[3][3] = {};
  double Q[3][3] = {};
};

/// The axis block of a one-axis motion model.
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

/// One mode of W lanes: its prediction, its update, the innovation and S it updated with.
template <int D, int W>
struct ModeLanes {
  static constexpr int N = 2 * D;
  double x[N][W];     // predicted mean
  double P[N][N][W];  // predicted covariance
  double xu[N][W];    // updated mean
  double U[N][N][W];  // updated covariance
  double nu[2][W];    // the innovation of the update
  double s[3][W];     // its S: s00, s01, s11
  double log_likelihood[W], code[W];
};

/// A mode's linearization at a point: H's two columns at the position (x, y), R, the innovation,
/// the predicted plot and whether h is defined there.
template <int W>
struct Linearization {
  double h[2][2][W];
  double r00[W], r01[W], r11[W], nu0[W], nu1[W], z_hat0[W], z_hat1[W], defined[W];
};

/// F x: the predicted mean of a mixed mean, per axis block.
template <int D, int W>
[[gnu::always_inline]] inline void predict_mean(const AxisModel& model,
                                                const double (&mean)[2 * D][W],
                                                double (&out)[2 * D][W]) {
  for (int i = 0; i < 2 * D; ++i) {
    const int axis = i / D, r = i % D;
    IMM_LANES {
      double sum = 0.0;
      for (int c = 0; c < D; ++c) sum += model.F[r][c] * mean[axis * D + c][l];
      out[i][l] = sum;
    }
  }
}

/// The prediction of a mixed condition (KalmanMode::propose): x⁻ = F x, P⁻ = F P Fᵀ + Q,
/// symmetrized, per axis block (F and Q are block-diagonal).
template <int D, int W>
[[gnu::always_inline]] inline void predict(const AxisModel& model, const double (&mean)[2 * D][W],
                                           const double (&mixed)[2 * D][2 * D][W],
                                           ModeLanes<D, W>& mode) {
  constexpr int N = 2 * D;
  predict_mean<D, W>(model, mean, mode.x);
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

/// P Hᵀ (N × 2) and S = H P Hᵀ + R, symmetrized, of a prediction P under a linearization.
template <int D, int W>
[[gnu::always_inline]] inline void innovation_covariance(const Linearization<W>& g,
                                                         const double (&P)[2 * D][2 * D][W],
                                                         double (&pht)[2 * D][2][W],
                                                         double (&S)[3][W]) {
  const auto& h = g.h;
  for (int a = 0; a < 2 * D; ++a) {
    for (int m = 0; m < 2; ++m) {
      IMM_LANES pht[a][m][l] = P[a][0][l] * h[m][0][l] + P[a][D][l] * h[m][1][l];
    }
  }
  IMM_LANES {
    const double s00 = (h[0][0][l] * pht[0][0][l] + h[0][1][l] * pht[D][0][l]) + g.r00[l];
    const double s01 = (h[0][0][l] * pht[0][1][l] + h[0][1][l] * pht[D][1][l]) + g.r01[l];
    const double s10 = (h[1][0][l] * pht[0][0][l] + h[1][1][l] * pht[D][0][l]) + g.r01[l];
    const double s11 = (h[1][0][l] * pht[0][1][l] + h[1][1][l] * pht[D][1][l]) + g.r11[l];
    S[0][l] = s00;
    S[1][l] = 0.5 * (s01 + s10);
    S[2][l] = s11;
  }
}

/// The Joseph-form update of a mode's prediction with its linearization (update_with_innovation
/// with H's non-zero columns 0 and D) into xu and U, with ν, S, the log-likelihood and the outcome
/// code.
template <int D, int W>
[[gnu::always_inline]] inline void update_mode(const Linearization<W>& g, ModeLanes<D, W>& mode) {
  constexpr int N = 2 * D;
  const auto& h = g.h;
  double pht[N][2][W];
  innovation_covariance<D, W>(g, mode.P, pht, mode.s);
  double si[2][2][W], log_det[W], valid[W];
  IMM_LANES {
    const double S[2][2] = {{mode.s[0][l], mode.s[1][l]}, {mode.s[1][l], mode.s[2][l]}};
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
      mode.xu[a][l] = mode.x[a][l] + (K[a][0][l] * g.nu0[l] + K[a][1][l] * g.nu1[l]);
      mode.U[a][a][l] = updated[a][a][l];
      zero[l] += mode.xu[a][l] * 0.0 + updated[a][a][l] * 0.0;
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
    mode.nu[0][l] = n0;
    mode.nu[1][l] = n1;
    const double mahalanobis =
        n0 * (si[0][0][l] * n0 + si[0][1][l] * n1) + n1 * (si[1][0][l] * n0 + si[1][1][l] * n1);
    mode.log_likelihood[l] = -0.5 * (mahalanobis + log_det[l] + 2.0 * kLogTwoPi);
    mode.code[l] = pick(g.defined[l] == 0.0, kUndefined,
                        pick(valid[l] != 0.0, pick(zero[l] == 0.0, kOk, kNonFinite), kSingular));
  }
}

}  // namespace imm::bank
