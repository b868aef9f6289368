// SPDX-License-Identifier: Apache-2.0
#pragma once
// A FIMM mode's measurement and update over W lanes (seed 003 with the TSK sensor model of the
// FCRM paper): h and its Jacobian from the TSK rules (TskSensorModel::evaluate in its order, with
// lane_exp for the rules' weights), the linearization and the EKF or iterated EKF update
// (iterated_update's rule). W = 1 is the one-track FIMM's mode (fimm.cpp), a block of 8 lanes the
// FimmTrackBank's, so a track's mode step is the same operations in both. Not installed.

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "filters/position_kalman_step.hpp"
#include "imm/estimation/kalman_filter.hpp"
#include "imm/filters/fimm.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/models/learned/tsk_sensor_model.hpp"
#include "imm/models/motion/constant_acceleration.hpp"

namespace imm::fimm {

using bank::AxisModel;
using bank::kOk;
using bank::Linearization;
using bank::ModeLanes;
using bank::update_mode;

/// Both modes are CA: 3 states per axis, the mixing space's own.
inline constexpr int kAxis = 3;

/// The TSK sensor model's rules and box, flattened for loops over lanes.
struct TskConstants {
  struct Rule {
    double m0, m1, s0, s1, a0, a1, a2;  // centers, widths, consequent
  };
  std::array<std::array<Rule, kTskMaxRules>, 2> rules{};  // per output
  std::array<int, 2> rule_count{};
  bool product = false;  // the t-norm: product, else min
  bool linear = true;    // outside the box: linear continuation, else hold
  double lower0 = 0.0, lower1 = 0.0, upper0 = 0.0, upper1 = 0.0;

  TskConstants() = default;
  explicit TskConstants(const TskSensorModel& model)
      : product(model.t_norm() == TNorm::kProduct),
        linear(model.outside_policy() == OutsideBox::kLinear),
        lower0(model.input_lower()(0)),
        lower1(model.input_lower()(1)),
        upper0(model.input_upper()(0)),
        upper1(model.input_upper()(1)) {
    for (std::size_t i = 0; i < 2; ++i) {
      const std::vector<TskRule>& output = model.outputs()[i].rules;
      rule_count[i] = static_cast<int>(std::min<std::size_t>(output.size(), kTskMaxRules));
      for (int r = 0; r < rule_count[i]; ++r) {
        const TskRule& rule = output[static_cast<std::size_t>(r)];
        rules[i][static_cast<std::size_t>(r)] = {
            rule.center(0),     rule.center(1),     rule.width(0),     rule.width(1),
            rule.consequent(0), rule.consequent(1), rule.consequent(2)};
      }
    }
  }
};

/// What a FIMM mode's step reads: both modes' axis models, R with the sensor's noise, the sensor,
/// the iterations.
struct Constants {
  std::array<AxisModel, 2> modes;
  double r00 = 0.0, r01 = 0.0, r11 = 0.0;  // R, with the sensor model's own noise
  bool sensor = false;                     // false: h = identity
  TskConstants tsk;
  int iterations = 1;
};

/// A FIMM mode over W lanes.
template <int W>
using Mode = ModeLanes<kAxis, W>;

/// h and its Jacobian at (ξ, η) over lanes: TskSensorModel::evaluate (fire and output per output,
/// then the box's policy) in its order, with lane_exp for the rules' weights.
template <int W>
[[gnu::always_inline]] inline void tsk_lanes(const TskConstants& t, const double* xi,
                                             const double* eta, double (&h)[2][W],
                                             double (&H)[2][2][W]) {
  double x0[W], x1[W], inside0[W], inside1[W];
  IMM_LANES {
    x0[l] = pick(xi[l] < t.lower0, t.lower0, xi[l]);
    x0[l] = pick(t.upper0 < x0[l], t.upper0, x0[l]);
    x1[l] = pick(eta[l] < t.lower1, t.lower1, eta[l]);
    x1[l] = pick(t.upper1 < x1[l], t.upper1, x1[l]);
    inside0[l] = pick((xi[l] >= t.lower0) & (xi[l] <= t.upper0), 1.0, 0.0);
    inside1[l] = pick((eta[l] >= t.lower1) & (eta[l] <= t.upper1), 1.0, 0.0);
  }
  for (std::size_t i = 0; i < 2; ++i) {
    const int n = t.rule_count[i];
    const auto& rules = t.rules[i];
    // log wʳ (the product's sum or the min's smaller term, the first at a tie), the largest.
    double u0[kTskMaxRules][W], u1[kTskMaxRules][W], log_w[kTskMaxRules][W];
    double active0[kTskMaxRules][W], largest[W];
    IMM_LANES largest[l] = -std::numeric_limits<double>::infinity();
    for (int r = 0; r < n; ++r) {
      const TskConstants::Rule& rule = rules[static_cast<std::size_t>(r)];
      IMM_LANES {
        u0[r][l] = (x0[l] - rule.m0) / rule.s0;
        u1[r][l] = (x1[l] - rule.m1) / rule.s1;
        const double a0 = -0.5 * u0[r][l] * u0[r][l], a1 = -0.5 * u1[r][l] * u1[r][l];
        const bool second = a1 < a0;
        log_w[r][l] = t.product ? a0 + a1 : pick(second, a1, a0);
        active0[r][l] = t.product ? 1.0 : pick(second, 0.0, 1.0);
        largest[l] = pick(log_w[r][l] > largest[l], log_w[r][l], largest[l]);
      }
    }
    // h = Σ wʳ zʳ / Σ wʳ, wʳ scaled by the largest.
    double share[kTskMaxRules][W], z[kTskMaxRules][W], sum_w[W], sum_wz[W];
    IMM_LANES sum_w[l] = sum_wz[l] = 0.0;
    for (int r = 0; r < n; ++r) {
      const TskConstants::Rule& rule = rules[static_cast<std::size_t>(r)];
      IMM_LANES {
        share[r][l] = lane_exp_no_overflow(log_w[r][l] - largest[l]);
        z[r][l] = rule.a0 + rule.a1 * x0[l] + rule.a2 * x1[l];
        sum_w[l] += share[r][l];
        sum_wz[l] += share[r][l] * z[r][l];
      }
    }
    // ∂h/∂x = Σ shareʳ [∂ log wʳ/∂x (zʳ − h) + a_xʳ], ∂ log A/∂x = −u/s on the active inputs.
    double value[W], g0[W], g1[W];
    IMM_LANES {
      value[l] = sum_wz[l] / sum_w[l];
      g0[l] = g1[l] = 0.0;
    }
    for (int r = 0; r < n; ++r) {
      const TskConstants::Rule& rule = rules[static_cast<std::size_t>(r)];
      IMM_LANES {
        const double weight = share[r][l] / sum_w[l];
        const double d0 = active0[r][l] * (-u0[r][l] / rule.s0);
        const double d1 = (t.product ? 1.0 : 1.0 - active0[r][l]) * (-u1[r][l] / rule.s1);
        const double spread = z[r][l] - value[l];
        g0[l] += weight * (d0 * spread + rule.a1);
        g1[l] += weight * (d1 * spread + rule.a2);
      }
    }
    // Outside the box: the linear continuation from the clamped point, or the value held there.
    IMM_LANES {
      const bool clamped = (inside0[l] == 0.0) | (inside1[l] == 0.0);
      const double continued = value[l] + (g0[l] * (xi[l] - x0[l]) + g1[l] * (eta[l] - x1[l]));
      h[i][l] = pick(clamped & t.linear, continued, value[l]);
      H[i][0][l] = pick(clamped & !t.linear, g0[l] * inside0[l], g0[l]);
      H[i][1][l] = pick(clamped & !t.linear, g1[l] * inside1[l], g1[l]);
    }
  }
}

/// The linearization of every lane at `point`: H = ∇h there and the innovation
/// z − h(point) − H (x⁻ − point) (iterated_update; the last term is 0 at x⁻, the EKF).
template <int W>
[[gnu::always_inline]] inline void linearize(const Constants& b, const double* z0, const double* z1,
                                             const Mode<W>& mode, const double (&point)[6][W],
                                             Linearization<W>& g) {
  double h[2][W];
  if (b.sensor) {
    tsk_lanes<W>(b.tsk, point[0], point[kAxis], h, g.h);
  } else {
    IMM_LANES {
      h[0][l] = point[0][l];
      h[1][l] = point[kAxis][l];
      g.h[0][0][l] = g.h[1][1][l] = 1.0;
      g.h[0][1][l] = g.h[1][0][l] = 0.0;
    }
  }
  IMM_LANES {
    g.r00[l] = b.r00;
    g.r01[l] = b.r01;
    g.r11[l] = b.r11;
    // x * 0 is 0 for a finite x and NaN otherwise (TskSensorMeasurement::defined_at).
    double zero = 0.0;
    for (int a = 0; a < 6; ++a) zero += point[a][l] * 0.0;
    g.defined[l] = pick(zero == 0.0, 1.0, 0.0);
    const double d0 = mode.x[0][l] - point[0][l], d1 = mode.x[kAxis][l] - point[kAxis][l];
    g.z_hat0[l] = h[0][l];
    g.z_hat1[l] = h[1][l];
    g.nu0[l] = (z0[l] - h[0][l]) - (g.h[0][0][l] * d0 + g.h[0][1][l] * d1);
    g.nu1[l] = (z1[l] - h[1][l]) - (g.h[1][0][l] * d0 + g.h[1][1][l] * d1);
  }
}

/// A mode's update (KalmanMode::propose): the EKF, or the iterated EKF lane by lane — a lane stops
/// at a failed update (its status stands) or once its step, relative to the prior's standard
/// deviations, is below the tolerance, and keeps that iteration's result.
template <int W>
[[gnu::always_inline]] inline void update(const Constants& b, const double* z0, const double* z1,
                                          Mode<W>& mode) {
  double point[6][W], active[W];
  for (int a = 0; a < 6; ++a) IMM_LANES point[a][l] = mode.x[a][l];
  IMM_LANES active[l] = 1.0;
  Linearization<W> g;  // NOLINT(cppcoreguidelines-pro-type-member-init): written first
  const int iterations = b.sensor ? b.iterations : 1;
  if (iterations <= 1) {
    linearize<W>(b, z0, z1, mode, point, g);
    update_mode<kAxis, W>(g, mode);
    return;
  }
  double scale[6][W];
  for (int a = 0; a < 6; ++a) {
    IMM_LANES {
      const double s = std::sqrt(mode.P[a][a][l]);
      scale[a][l] = pick(s > 1e-300, s, 1e-300);
    }
  }
  if constexpr (W == 1) {
    // One lane stops where it stops: the iteration it keeps is the last one run, already in
    // `mode` (the lanes below keep it by copies, since their neighbours may go on).
    for (int i = 0; i < iterations; ++i) {
      linearize<1>(b, z0, z1, mode, point, g);
      update_mode<kAxis, 1>(g, mode);
      if (mode.code[0] != kOk) return;
      double step = 0.0;
      for (int a = 0; a < 6; ++a) {
        const double s = std::abs(mode.xu[a][0] - point[a][0]) / scale[a][0];
        step = pick(s > step, s, step);
        point[a][0] = mode.xu[a][0];
      }
      if (step < kIteratedUpdateTolerance) return;
    }
    return;
  }
  double xu[6][W] = {}, U[6][6][W] = {}, nu[2][W] = {}, innovation_covariance[3][W] = {};
  double log_likelihood[W] = {}, code[W] = {};
  for (int i = 0; i < iterations; ++i) {
    linearize<W>(b, z0, z1, mode, point, g);
    update_mode<kAxis, W>(g, mode);
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
      for (int m = 0; m < 2; ++m) nu[m][l] = pick(taken, mode.nu[m][l], nu[m][l]);
      for (int m = 0; m < 3; ++m) {
        innovation_covariance[m][l] = pick(taken, mode.s[m][l], innovation_covariance[m][l]);
      }
      active[l] =
          pick(taken & (mode.code[l] == kOk) & !(step < kIteratedUpdateTolerance), 1.0, 0.0);
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
    for (int m = 0; m < 2; ++m) mode.nu[m][l] = nu[m][l];
    for (int m = 0; m < 3; ++m) mode.s[m][l] = innovation_covariance[m][l];
  }
}

/// The constants of a spec and its sensor (null: h = identity).
inline Constants constants_of(const FimmSpec& spec, const TskSensorModel* sensor) {
  Constants b;
  for (int j = 0; j < 2; ++j) {
    b.modes[static_cast<std::size_t>(j)] = bank::axis_model<kAxis>(
        constant_acceleration<1>(spec.sample_period, spec.process_noise(j)));
  }
  Eigen::Matrix2d R = spec.measurement_covariance;
  if (sensor != nullptr) R += sensor->noise_covariance();
  b.r00 = R(0, 0);
  b.r01 = R(0, 1);
  b.r11 = R(1, 1);
  b.sensor = sensor != nullptr;
  if (sensor != nullptr) b.tsk = TskConstants(*sensor);
  b.iterations = spec.iterations;
  return b;
}

}  // namespace imm::fimm
