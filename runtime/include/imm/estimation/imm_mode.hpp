// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// One mode (sub-model) of an IMM, as the IMM sees it. The IMM only mixes, asks its modes to
/// predict and update, reweights them by likelihood and combines; a mode owns its own state
/// (of any dimension ≤ NX) and decides how it predicts and updates. A plain Kalman mode,
/// a fuzzy-noise KF, an input-estimating KF and an EKF through a learned sensor model differ only
/// here.
///
/// Contract: propose*() computes the mode's next estimate into a pending slot and must not change
/// what embedded_estimate() returns; commit() makes the pending estimate current. The IMM commits
/// only when every mode succeeded, so a failed step leaves the whole filter untouched.
/// Implementations must not allocate in propose*() or commit().

#include <string_view>

#include "imm/estimation/gaussian_state.hpp"
#include "imm/estimation/step_status.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// What a mode's propose step returns.
struct IMM_RUNTIME_EXPORT ModeStep {
  /// kOk, or why the mode left its estimate unchanged.
  StepStatus status = StepStatus::kOk;
  double log_likelihood = 0.0;  ///< log N(ν; 0, S); 0 for a prediction without measurement
};

/// One mode of an IMM: a filter over a NX-dimensional mixing space with NZ-dimensional
/// measurements. Steps are two-phase: propose*() computes a pending estimate, commit() makes it
/// current.
template <int NX, int NZ>
class ImmMode {
 public:
  /// The mixing-space dimension.
  static constexpr int kMixingDim = NX;
  /// The measurement dimension.
  static constexpr int kMeasurementDim = NZ;

  ImmMode() = default;
  ImmMode(const ImmMode&) = delete;
  ImmMode& operator=(const ImmMode&) = delete;
  virtual ~ImmMode() = default;

  /// Human-readable name (from the config or model file).
  [[nodiscard]] virtual std::string_view name() const = 0;

  /// The current estimate in mixing-space coordinates, zero-padded.
  virtual void embedded_estimate(Vector<NX>& mean, SquareMatrix<NX>& covariance) const = 0;

  /// Sets the current estimate from a mixing-space Gaussian (track initialization).
  virtual void reset(const GaussianState<NX>& state) = 0;

  /// Predicts from the mixed initial condition and updates with z (seed 000 eq. 7 / 19).
  virtual ModeStep propose(const GaussianState<NX>& mixed, const Vector<NZ>& z) = 0;

  /// Predicts from the mixed initial condition without a measurement.
  virtual ModeStep propose_prediction(const GaussianState<NX>& mixed) = 0;

  /// The mean the mode would predict from the mixed initial condition, in mixing-space
  /// coordinates (zero-padded); nothing of the mode changes.
  virtual void predicted_mean(const GaussianState<NX>& mixed, Vector<NX>& mean) const = 0;

  /// Makes the pending estimate of the last successful propose*() current.
  virtual void commit() = 0;

  /// Whether the mode predicts over any positive interval (set_interval), not only over the one
  /// sample period it was built for.
  [[nodiscard]] virtual bool takes_any_interval() const { return false; }
  /// Makes the following predictions span `interval` s (positive, finite) until the next call:
  /// F and Q remade for it without allocating. Only where takes_any_interval(); otherwise, or for
  /// an interval the model cannot take, false and nothing changes.
  virtual bool set_interval(double /*interval*/) { return false; }

  /// Whether the mode's prediction does not depend on the plot, so that the IMM can predict
  /// first and score candidate plots before it updates (ImmEstimator::predict). A mode whose
  /// process noise or compensation is set by the plot's own innovation cannot.
  [[nodiscard]] virtual bool predicts_before_the_plot() const { return false; }
  /// After propose_prediction(): the innovation ν = z − ẑ of a candidate plot (in the mode's plot
  /// coordinates, angles wrapped) and its covariance S = H P⁻ Hᵀ + R at the pending prediction
  /// (the first linearization, for an EKF); nothing changes. False where z or the prediction
  /// cannot be scored.
  virtual bool candidate_innovation(const Vector<NZ>& /*z*/, Vector<NZ>& /*nu*/,
                                    SquareMatrix<NZ>& /*S*/) const {
    return false;
  }
  /// After propose_prediction(): the predicted plot ẑ = h(x⁻) and S; false where h is undefined.
  virtual bool predicted_plot(Vector<NZ>& /*z_hat*/, SquareMatrix<NZ>& /*S*/) const {
    return false;
  }
  /// After propose_prediction(): the update of that prediction with z, pending until commit() —
  /// the same numbers as propose() of the same mixed estimate and z. It may be called again with
  /// another plot; the prediction stays.
  virtual ModeStep propose_update(const Vector<NZ>& /*z*/) {
    return {StepStatus::kInvalidMeasurement, 0.0};
  }

  /// The innovation ν = z − ẑ of the last propose() with a measurement, in the coordinates the
  /// mode updated in (wrapped where angular), and its covariance S: what the IMM's normalized
  /// innovation squared is built from (ImmEstimator::innovation). Zero before the first one.
  [[nodiscard]] const Vector<NZ>& innovation() const { return innovation_; }
  /// S of innovation().
  [[nodiscard]] const SquareMatrix<NZ>& innovation_covariance() const {
    return innovation_covariance_;
  }

 protected:
  /// For propose(): keeps the update's ν and S (no allocation).
  void keep_innovation(const Vector<NZ>& innovation, const SquareMatrix<NZ>& covariance) {
    innovation_ = innovation;
    innovation_covariance_ = covariance;
  }
  /// For propose(): ν and S written in place, entry by entry.
  Vector<NZ>& kept_innovation() { return innovation_; }
  /// S of kept_innovation().
  SquareMatrix<NZ>& kept_innovation_covariance() { return innovation_covariance_; }

 private:
  Vector<NZ> innovation_ = Vector<NZ>::Zero();
  SquareMatrix<NZ> innovation_covariance_ = SquareMatrix<NZ>::Zero();
};

}  // namespace imm
