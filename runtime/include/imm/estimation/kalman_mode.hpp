// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The plain IMM mode: a Kalman filter with a fixed linear motion model and a measurement model
/// (linear or, through its Jacobian, extended).

#include <cmath>
#include <string>
#include <string_view>
#include <utility>

#include "imm/estimation/imm_mode.hpp"
#include "imm/estimation/kalman_filter.hpp"
#include "imm/estimation/kalman_mode_base.hpp"
#include "imm/estimation/state_embedding.hpp"
#include "imm/models/motion/motion_model.hpp"

namespace imm {

/// A linear-motion Kalman mode of N states inside an NX-state mixing space, with any measurement
/// model (Joseph-form update).
template <int NX, int N, class MeasurementModel>
class KalmanMode final : public KalmanModeBase<NX, N, MeasurementModel> {
  using Base = KalmanModeBase<NX, N, MeasurementModel>;
  using Base::embedding_;
  using Base::estimate_;
  using Base::measurement_;
  using Base::predicted_;

 public:
  /// The mode's own state dimension.
  static constexpr int kDim = N;
  using Base::kMeasurementDim;

  /// `iterations` > 1: the iterated EKF update (kalman_filter.hpp) for nonlinear measurements.
  /// `maker`, when given, remakes the motion for other intervals (set_interval).
  KalmanMode(std::string name, const LinearMotionModel<N>& motion,
             const MeasurementModel& measurement, const StateEmbedding<N, NX>& embedding,
             int iterations = 1, MotionMaker<LinearMotionModel<N>> maker = {})
      : Base(std::move(name), measurement, embedding),
        motion_(motion),
        iterations_(iterations),
        maker_(maker) {}

  /// Whether a maker was given.
  [[nodiscard]] bool takes_any_interval() const override { return static_cast<bool>(maker_); }
  /// F and Q over `interval` (ImmMode::set_interval).
  bool set_interval(double interval) override {
    if (!maker_ || !(interval > 0.0) || !std::isfinite(interval)) return false;
    if (interval != interval_) {
      const LinearMotionModel<N> motion = maker_(interval);
      if (!motion.transition.allFinite() || !motion.process_noise.allFinite()) return false;
      motion_ = motion;
      interval_ = interval;
    }
    return true;
  }

  void reset(const GaussianState<NX>& state) override { estimate_ = embedding_.project(state); }

  /// Predicts from the mixed estimate (projected to the mode's states) and updates with z; pending
  /// until commit().
  [[gnu::flatten]] ModeStep propose(const GaussianState<NX>& mixed,
                                    const Vector<kMeasurementDim>& z) override {
    pending_ = predict(embedding_.project(mixed), motion_.transition, motion_.process_noise);
    return update_pending(z);
  }

  ModeStep propose_prediction(const GaussianState<NX>& mixed) override {
    pending_ = predict(embedding_.project(mixed), motion_.transition, motion_.process_noise);
    predicted_ = pending_;
    return {pending_.all_finite() ? StepStatus::kOk : StepStatus::kNonFiniteResult, 0.0};
  }

  /// True: the prediction does not depend on the plot.
  [[nodiscard]] bool predicts_before_the_plot() const override { return true; }
  /// The held prediction updated with z (ImmMode::propose_update).
  ModeStep propose_update(const Vector<kMeasurementDim>& z) override {
    pending_ = predicted_;
    return update_pending(z);
  }

  void predicted_mean(const GaussianState<NX>& mixed, Vector<NX>& mean) const override {
    GaussianState<N> predicted = embedding_.project(mixed);
    predicted.mean = motion_.transition * predicted.mean;
    SquareMatrix<NX> unused;
    embedding_.embed(predicted, mean, unused);
  }

  void commit() override { estimate_ = pending_; }

  /// The mode's motion model.
  [[nodiscard]] const LinearMotionModel<N>& motion() const { return motion_; }

 private:
  // The update of pending_ (a prediction) with z.
  ModeStep update_pending(const Vector<kMeasurementDim>& z) {
    const auto report = iterated_update(pending_, z, measurement_, iterations_);
    this->keep_innovation(report.innovation, report.innovation_covariance);
    return {report.status, report.log_likelihood};
  }

  LinearMotionModel<N> motion_;
  int iterations_ = 1;
  MotionMaker<LinearMotionModel<N>> maker_;
  double interval_ = 0.0;  // the interval motion_ was last remade for (0: as built)
  GaussianState<N> pending_;
};

}  // namespace imm
