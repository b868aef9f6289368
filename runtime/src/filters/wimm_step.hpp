// SPDX-License-Identifier: Apache-2.0
#pragma once
// The weighted IMM's measurement over W lanes (seed 004 §3.2): the modes' predicted ranges and
// azimuths, θ̄ (the μ̄-weighted circular mean of the azimuths, eq. 9–11), the fusion's choice of
// azimuth (eq. 8) and each mode's linearization, in one of three readings:
//
// - the plain polar EKF, z = [r, θ] (the normal IMM; also the seed's fusion, whose fused azimuth
//   θ_f = θ̄ + α (θ_p − θ̄) is then an ordinary plot with R unchanged: linearized for one mode the
//   innovation becomes α ν_θ, so the state moves by α K ν while P shrinks as if by K ν);
// - the correlated fusion, the fused plot modelled honestly: with A = diag(1, α),
//   z_f = A z + (I − A) c, c = [·, θ̄] known, so h_f(x) = A h(x) + (I − A) c with Jacobian A H and
//   covariance A R Aᵀ. Its gain is K A⁻¹: the update is exactly the normal IMM's (fusing the
//   prediction into the plot adds no information);
// - the converted measurement: the plot as a Cartesian position with the linearized covariance
//   J R Jᵀ and a linear update.
//
// W = 1 is the one-track WimmFilter's (wimm.cpp), a block of 8 lanes the WimmTrackBank's, so a
// track's measurement and mode steps are the same operations in both. The azimuths are
// lane_atan2; the wraps (exact remainders) and the converted plot (libm's sin and cos) run per
// lane. Not installed.

#include <cmath>

#include "filters/position_kalman_step.hpp"
#include "imm/filters/wimm.hpp"
#include "imm/math/angle.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/models/measurement/polar_measurement.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/models/motion/singer.hpp"

namespace imm::wimm {

using bank::Linearization;

/// States per axis of the CV and the Singer mode; the mixing space has 3 ([p, v, a] per axis).
inline constexpr int kCvAxis = 2, kSingerAxis = 3;

/// What the wIMM's measurement and mode steps read.
struct Constants {
  bank::AxisModel cv, singer;
  double range_variance = 0.0, azimuth_variance = 0.0, threshold = 0.0, alpha = 1.0;
  bool fuse = false, correlated = false, converted = false;
};

/// The constants of a spec.
inline Constants constants_of(const WimmSpec& spec) {
  Constants b;
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

/// A predicted position's range and azimuth atan2(x, y) over lanes.
template <int W>
[[gnu::always_inline]] inline void range_and_azimuth(const double* x, const double* y, double* r,
                                                     double* azimuth) {
  IMM_LANES {
    r[l] = std::sqrt(x[l] * x[l] + y[l] * y[l]);
    azimuth[l] = lane_atan2(x[l], y[l]);
  }
}

/// θ̄ = atan2(Σ_j μ̄_j sin θ_j, Σ_j μ̄_j cos θ_j) with sin θ_j = x_j / r_j, cos θ_j = y_j / r_j; a
/// mode predicted at the radar (r_j = 0, its azimuth undefined) adds nothing, so θ̄ stays a number
/// and such a cycle fails as the mode's update says (an undefined measurement).
template <int W>
[[gnu::always_inline]] inline void theta_bar(const double (&predicted)[2][W],
                                             const double (&x)[2][W], const double (&y)[2][W],
                                             const double (&r)[2][W], double* out) {
  IMM_LANES {
    double s = 0.0, c = 0.0;
    for (int j = 0; j < 2; ++j) {
      const bool away = r[j][l] > 0.0;
      s += predicted[j][l] * pick(away, x[j][l] / r[j][l], 0.0);
      c += predicted[j][l] * pick(away, y[j][l] / r[j][l], 0.0);
    }
    out[l] = lane_atan2(s, c);
  }
}

/// Whether a track's cycle fuses (the CV mode's μ̄ above the threshold) and the azimuth it then
/// updates with.
struct Choice {
  bool fuse = false;
  double azimuth = 0.0;  ///< the plot's, or the fused θ̄ + α (θ_p − θ̄)
};

/// The choice of a track whose CV mode's μ̄ is `predicted_cv`, for plot azimuth `azimuth`.
inline Choice choose(const Constants& b, double predicted_cv, double azimuth, double theta_bar) {
  const bool fuse = b.fuse && predicted_cv > b.threshold;
  return {fuse, fuse ? blend_angles(azimuth, theta_bar, b.alpha) : azimuth};
}

/// The chosen plot (range, azimuth) as a Cartesian position with its linearized covariance.
inline CartesianPlot converted_plot(const Constants& b, double range, double azimuth) {
  return polar_to_cartesian(Vector<2>(range, azimuth),
                            Vector<2>(b.range_variance, b.azimuth_variance).asDiagonal());
}

/// Lane l of a mode's linearization under the converted update: the chosen plot `plot`
/// (converted_plot, made once for a track's modes) as a Cartesian position, H selecting the
/// mode's predicted position (x, y), R = J R Jᵀ.
template <int W>
[[gnu::always_inline]] inline void converted_lane(const CartesianPlot& plot, double x, double y,
                                                  Linearization<W>& g, int l) {
  g.h[0][0][l] = g.h[1][1][l] = 1.0;
  g.h[0][1][l] = g.h[1][0][l] = 0.0;
  g.r00[l] = plot.covariance(0, 0);
  g.r01[l] = plot.covariance(0, 1);
  g.r11[l] = plot.covariance(1, 1);
  g.z_hat0[l] = x;
  g.z_hat1[l] = y;
  g.nu0[l] = plot.position(0) - x;
  g.nu1[l] = plot.position(1) - y;
  g.defined[l] = 1.0;
}

/// Lane l of a mode's linearization under the polar (extended) update, at its predicted position
/// (x, y), range r and azimuth `predicted_azimuth`, for plot range `range` and the chosen
/// azimuth; the correlated fusion's where this cycle fuses.
template <int W>
[[gnu::always_inline]] inline void polar_lane(const Constants& b, bool fuse, double range,
                                              double azimuth, double theta_bar, double x, double y,
                                              double r, double predicted_azimuth,
                                              Linearization<W>& g, int l) {
  const bool correlated = fuse && b.correlated;
  const double r2 = x * x + y * y;
  const double a = correlated ? b.alpha : 1.0;
  g.h[0][0][l] = x / r;
  g.h[0][1][l] = y / r;
  g.h[1][0][l] = correlated ? y / r2 * a : y / r2;
  g.h[1][1][l] = correlated ? -x / r2 * a : -x / r2;
  g.r00[l] = b.range_variance;
  g.r01[l] = 0.0;
  g.r11[l] = correlated ? b.azimuth_variance * a * a : b.azimuth_variance;
  const double h_azimuth =
      correlated ? theta_bar + a * wrap_angle(predicted_azimuth - theta_bar) : predicted_azimuth;
  g.z_hat0[l] = r;
  g.z_hat1[l] = h_azimuth;
  g.nu0[l] = range - r;
  g.nu1[l] = wrap_angle(azimuth - h_azimuth);
  g.defined[l] = r > PolarMeasurement<6>::kMinimumRange ? 1.0 : 0.0;
}

}  // namespace imm::wimm
