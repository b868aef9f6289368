// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// What every Kalman mode of an IMM holds and answers the same way: its name, how its own states
/// sit in the mixing space, its estimate, its measurement model and the prediction it holds
/// between the split cycle's halves, with the innovation of a candidate plot and the predicted
/// plot at that prediction (ImmMode::candidate_innovation, predicted_plot). KalmanMode
/// (kalman_mode.hpp) and ScheduledNoiseMode (scheduled_noise_mode.hpp) derive from it; how they
/// predict and update is their own.

#include <string>
#include <string_view>
#include <utility>

#include "imm/estimation/imm_mode.hpp"
#include "imm/estimation/kalman_filter.hpp"
#include "imm/estimation/state_embedding.hpp"

namespace imm {

/// The common part of a Kalman mode of N own states in an NX-state mixing space, measured by a
/// MeasurementModel (see the file comment).
template <int NX, int N, class MeasurementModel>
class KalmanModeBase : public ImmMode<NX, MeasurementModel::kDim> {
 public:
  using ImmMode<NX, MeasurementModel::kDim>::kMeasurementDim;

  /// The mode's name.
  [[nodiscard]] std::string_view name() const override { return name_; }
  /// The estimate in the mixing space, zero-padded.
  void embedded_estimate(Vector<NX>& mean, SquareMatrix<NX>& covariance) const override {
    embedding_.embed(estimate_, mean, covariance);
  }
  /// ν and S of a candidate plot at the held prediction (ImmMode::candidate_innovation).
  bool candidate_innovation(const Vector<kMeasurementDim>& z, Vector<kMeasurementDim>& nu,
                            SquareMatrix<kMeasurementDim>& S) const override {
    return score_candidate(predicted_, z, measurement_, nu, S);
  }
  /// ẑ and S at the held prediction (ImmMode::predicted_plot).
  bool predicted_plot(Vector<kMeasurementDim>& z_hat,
                      SquareMatrix<kMeasurementDim>& S) const override {
    return predict_plot(predicted_, measurement_, z_hat, S);
  }

  /// The mode's current estimate in its own states.
  [[nodiscard]] const GaussianState<N>& estimate() const { return estimate_; }
  /// The mode's measurement model.
  [[nodiscard]] const MeasurementModel& measurement() const { return measurement_; }

 protected:
  /// A mode named `name`, measured by `measurement`, its states at `embedding` in the mixing
  /// space.
  KalmanModeBase(std::string name, const MeasurementModel& measurement,
                 const StateEmbedding<N, NX>& embedding)
      : name_(std::move(name)), measurement_(measurement), embedding_(embedding) {}

  std::string name_;                 ///< the mode's name
  MeasurementModel measurement_;     ///< how its state is measured
  StateEmbedding<N, NX> embedding_;  ///< where its states sit in the mixing space
  GaussianState<N> estimate_;        ///< its current estimate
  GaussianState<N> predicted_;       ///< the held prediction (propose_prediction's)
};

}  // namespace imm
