// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The coordinated-turn IMM mode: an extended Kalman filter whose prediction runs the CT model
/// (imm/models/motion/coordinated_turn.hpp) — the mean through the exact turn, the covariance
/// through its Jacobian, F P Fᵀ + Q — and whose update is the Joseph-form (or iterated) update of
/// any measurement model, as every mode's. Its state [x, vx, y, vy, ω] sits in the IMM's mixing
/// space through a StateEmbedding, beside CV and CA modes.

#include <string>
#include <string_view>
#include <utility>

#include "imm/estimation/imm_mode.hpp"
#include "imm/estimation/kalman_filter.hpp"
#include "imm/estimation/state_embedding.hpp"
#include "imm/models/motion/coordinated_turn.hpp"

namespace imm {

/// One EKF prediction of the CT model over T with process noise Q (symmetrized).
[[nodiscard]] inline GaussianState<kCoordinatedTurnDim> predict_turn(
    const GaussianState<kCoordinatedTurnDim>& state, double T,
    const SquareMatrix<kCoordinatedTurnDim>& Q) {
  const SquareMatrix<kCoordinatedTurnDim> F = coordinated_turn_jacobian(state.mean, T);
  GaussianState<kCoordinatedTurnDim> predicted;
  predicted.mean = coordinated_turn_step(state.mean, T);
  predicted.covariance.noalias() = F * state.covariance * F.transpose();
  predicted.covariance += Q;
  symmetrize(predicted.covariance);
  return predicted;
}

/// A coordinated-turn EKF mode of an NX-state mixing space, with any measurement model.
template <int NX, class MeasurementModel>
class CoordinatedTurnMode final : public ImmMode<NX, MeasurementModel::kDim> {
 public:
  /// The mode's own state dimension, [x, vx, y, vy, ω].
  static constexpr int kDim = kCoordinatedTurnDim;
  using ImmMode<NX, MeasurementModel::kDim>::kMeasurementDim;

  /// `process_noise`: coordinated_turn_noise(T, …); `iterations` > 1: the iterated EKF update.
  CoordinatedTurnMode(std::string name, double sample_period,
                      const SquareMatrix<kDim>& process_noise, const MeasurementModel& measurement,
                      const StateEmbedding<kDim, NX>& embedding, int iterations = 1)
      : name_(std::move(name)),
        sample_period_(sample_period),
        process_noise_(process_noise),
        measurement_(measurement),
        embedding_(embedding),
        iterations_(iterations) {}

  /// The mode's name.
  [[nodiscard]] std::string_view name() const override { return name_; }

  /// The estimate in the mixing space, zero-padded.
  void embedded_estimate(Vector<NX>& mean, SquareMatrix<NX>& covariance) const override {
    embedding_.embed(estimate_, mean, covariance);
  }

  /// Takes its components of a mixing-space Gaussian.
  void reset(const GaussianState<NX>& state) override { estimate_ = embedding_.project(state); }

  /// The EKF prediction from the mixed estimate, then the update with z; pending until commit().
  [[gnu::flatten]] ModeStep propose(const GaussianState<NX>& mixed,
                                    const Vector<kMeasurementDim>& z) override {
    pending_ = predict_turn(embedding_.project(mixed), sample_period_, process_noise_);
    if (!pending_.usable()) return {StepStatus::kNonFiniteResult, 0.0};
    const auto report = iterations_ > 1 ? iterated_update(pending_, z, measurement_, iterations_)
                                        : update(pending_, z, measurement_);
    this->keep_innovation(report.innovation, report.innovation_covariance);
    return {report.status, report.log_likelihood};
  }

  /// The EKF prediction alone (a missed plot); pending until commit().
  ModeStep propose_prediction(const GaussianState<NX>& mixed) override {
    pending_ = predict_turn(embedding_.project(mixed), sample_period_, process_noise_);
    return {pending_.usable() ? StepStatus::kOk : StepStatus::kNonFiniteResult, 0.0};
  }

  /// The mean the turn predicts from the mixed estimate, zero-padded; nothing changes.
  void predicted_mean(const GaussianState<NX>& mixed, Vector<NX>& mean) const override {
    GaussianState<kDim> predicted = embedding_.project(mixed);
    predicted.mean = coordinated_turn_step(predicted.mean, sample_period_);
    SquareMatrix<NX> unused;
    embedding_.embed(predicted, mean, unused);
  }

  /// Makes the pending estimate current.
  void commit() override { estimate_ = pending_; }

  /// The mode's current estimate in its own states.
  [[nodiscard]] const GaussianState<kDim>& estimate() const { return estimate_; }
  /// The mode's measurement model.
  [[nodiscard]] const MeasurementModel& measurement() const { return measurement_; }

 private:
  std::string name_;
  double sample_period_;
  SquareMatrix<kDim> process_noise_;
  MeasurementModel measurement_;
  StateEmbedding<kDim, NX> embedding_;
  int iterations_ = 1;
  GaussianState<kDim> estimate_;
  GaussianState<kDim> pending_;
};

}  // namespace imm
