// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Learning the plot σ of a Cartesian sensor from the plots alone (a recorded regime's
/// `sigma = "estimate"`): the σ, with the quiet and manoeuvring process noises q₁ ≤ q₂ of a
/// two-mode constant-velocity IMM per axis, that maximizes the IMM's own predictive likelihood of
/// the plots, Σ_k log Σ_j c_j(k) N(ν_j(k); 0, S_j(k)) over both axes of every track. No truth is
/// needed: a CV model's predictions tell the plot noise (white, seen at every scan) from the
/// target's acceleration (integrated twice, seen as a drift), and the second mode keeps the
/// manoeuvres from being taken for plot noise.

#include "imm/datasets/regime.hpp"
#include "imm/datasets/track.hpp"

namespace imm::datasets {

/// The one-axis constant-velocity IMM a σ is fitted with.
struct AxisImmModel {
  double sample_period = 1.0;
  double sigma = 1.0;                                ///< plot σ per axis
  double quiet_noise = 1e-4, manoeuvre_noise = 1.0;  ///< q₁ ≤ q₂, (unit/s²)²
  double stay = 0.95;                                ///< p_jj of both modes
};

/// Σ log p(z | Z^(k−1)) of the plots of every track on both axes: each axis starts (two-point)
/// from its first two plots and is scored from the third on; NaN plots are predicted through. The
/// second value counts the plots scored. A step that fails scores −∞.
[[nodiscard]] std::pair<double, long> axis_imm_log_likelihood(const TrackSet& set,
                                                              const AxisImmModel& model);

struct PlotSigmaFit {
  AxisImmModel model;  ///< the maximum-likelihood σ, q₁ and q₂
  double log_likelihood = 0.0;
  long plots = 0;
  double start_sigma = 0.0;  ///< the robust start: MAD of the plots' second differences / √6
};

/// The maximum-likelihood σ, q₁, q₂ of a set's plots (the regime's sample period).
[[nodiscard]] PlotSigmaFit fit_plot_sigma(const TrackSet& set);

/// A polar sensor's σ_r and σ_θ from the plots alone: range and azimuth (unwrapped along each
/// track) are each fitted as a one-axis coordinate of fit_plot_sigma — over a scan a target's
/// range and bearing drift smoothly, and the manoeuvring mode takes the bearing's curvature.
struct PolarSigmaFit {
  PlotSigmaFit range, azimuth;  ///< σ_r in the set's unit, σ_θ in rad
};
[[nodiscard]] PolarSigmaFit fit_polar_sigma(const TrackSet& set);

/// A recorded regime's σ, fitted on its training split (what `sigma = "estimate"` resolves to).
[[nodiscard]] double estimate_plot_sigma(const Regime& regime);

}  // namespace imm::datasets
