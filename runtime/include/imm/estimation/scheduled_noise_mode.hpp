// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// An IMM mode whose process noise a fuzzy rule table schedules: the idea of the GA-fuzzy IMM
/// (seed 000 §3.2, imm/filters/fuzzy_noise_filter.hpp) carried over to the modes of the classical
/// CV/CA/CT IMM. Each step
///   x̂⁻ = f(x̂₀),  P̄ = F P₀ Fᵀ                          (F the Jacobian of f at x̂₀)
///   ν̄ = z − h(x̂⁻),  S̄ = H P̄ Hᵀ + R                      (before this step's process noise)
///   d(k) = √(ν̄ᵀ S̄⁻¹ ν̄),  Δd(k) = d(k) − d(k−1)
///   s(k) = table(d, Δd),  P⁻ = P̄ + s(k) Q
///   then the Joseph-form (or iterated) update with z, as every mode's.
/// d is the 2-D form of the GA's normalized innovation: dimensionless, about χ with 2 degrees of
/// freedom while the mode fits the target, so one table reads alike at any plot σ, unit and period.
/// The table's consequents are dimensionless multipliers of the mode's tuned Q (both the linear
/// acceleration and, for a CT mode, the turn-rate intensity); a table whose every consequent is 1
/// gives exactly the unscheduled mode. A missed plot predicts with the last step's multiplier.
/// A new track starts with d(−1) = 0 and the table's mean multiplier.
///
/// Without a table the mode's Q is fixed (P⁻ = F P₀ Fᵀ + Q, d is not computed): that is the
/// coordinated-turn EKF mode of the classical IMM (turn_mode.hpp).

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "imm/estimation/imm_mode.hpp"
#include "imm/estimation/kalman_filter.hpp"
#include "imm/estimation/kalman_mode_base.hpp"
#include "imm/estimation/state_embedding.hpp"
#include "imm/models/learned/fuzzy_rule_table.hpp"
#include "imm/models/motion/coordinated_turn.hpp"
#include "imm/models/motion/motion_model.hpp"

namespace imm {

/// The motion of a linear mode (CV, CA, Singer) for ScheduledNoiseMode.
template <int N>
struct LinearMotionStep {
  /// The state dimension.
  static constexpr int kDim = N;
  /// F and the tuned Q.
  LinearMotionModel<N> model;
  /// F x.
  [[nodiscard]] Vector<N> mean(const Vector<N>& x) const { return model.transition * x; }
  /// F (the same at every x).
  [[nodiscard]] const SquareMatrix<N>& jacobian(const Vector<N>& /*x*/) const {
    return model.transition;
  }
  /// The tuned Q the schedule scales.
  [[nodiscard]] const SquareMatrix<N>& noise() const { return model.process_noise; }
};

/// The motion of a coordinated-turn mode (imm/models/motion/coordinated_turn.hpp).
struct TurnMotionStep {
  /// [x, vx, y, vy, ω].
  static constexpr int kDim = kCoordinatedTurnDim;
  /// T, s (unset: from the spec).
  double sample_period = 0.0;
  /// The tuned Q (coordinated_turn_noise) the schedule scales.
  SquareMatrix<kDim> process_noise = SquareMatrix<kDim>::Zero();
  /// The exact turn over T.
  [[nodiscard]] Vector<kDim> mean(const Vector<kDim>& x) const {
    return coordinated_turn_step(x, sample_period);
  }
  /// The turn's Jacobian at x.
  [[nodiscard]] SquareMatrix<kDim> jacobian(const Vector<kDim>& x) const {
    return coordinated_turn_jacobian(x, sample_period);
  }
  /// The tuned Q.
  [[nodiscard]] const SquareMatrix<kDim>& noise() const { return process_noise; }
};

/// A mode of an NX-state mixing space whose Q a rule table scales (see the file comment).
template <int NX, class Motion, class MeasurementModel>
class ScheduledNoiseMode final : public KalmanModeBase<NX, Motion::kDim, MeasurementModel> {
  using Base = KalmanModeBase<NX, Motion::kDim, MeasurementModel>;
  using Base::embedding_;
  using Base::estimate_;
  using Base::measurement_;
  using Base::predicted_;

 public:
  /// The mode's own state dimension.
  static constexpr int kDim = Motion::kDim;
  using Base::kMeasurementDim;

  /// `iterations` > 1: the iterated EKF update; no `schedule`: a fixed Q. `maker`, when given,
  /// remakes the motion for other intervals (set_interval) — only without a schedule, whose
  /// table was learned at the sample period it was built for.
  ScheduledNoiseMode(std::string name, const Motion& motion, std::optional<FuzzyRuleTable> schedule,
                     const MeasurementModel& measurement, const StateEmbedding<kDim, NX>& embedding,
                     int iterations = 1, MotionMaker<Motion> maker = {})
      : Base(std::move(name), measurement, embedding),
        motion_(motion),
        schedule_(std::move(schedule)),
        iterations_(iterations),
        maker_(maker) {}

  /// Without a schedule, whether a maker was given.
  [[nodiscard]] bool takes_any_interval() const override {
    return !schedule_ && static_cast<bool>(maker_);
  }
  /// The motion over `interval` (ImmMode::set_interval).
  bool set_interval(double interval) override {
    if (!takes_any_interval() || !(interval > 0.0) || !std::isfinite(interval)) return false;
    if (interval != interval_) {
      const Motion motion = maker_(interval);
      if (!motion.noise().allFinite()) return false;
      motion_ = motion;
      interval_ = interval;
    }
    return true;
  }

  /// Takes its components of a mixing-space Gaussian and starts the schedule afresh.
  void reset(const GaussianState<NX>& state) override {
    estimate_ = embedding_.project(state);
    distance_ = 0.0;
    multiplier_ = schedule_ ? schedule_->mean_w() : 1.0;
  }

  /// The scheduled prediction from the mixed estimate, then the update with z; pending until
  /// commit().
  [[gnu::flatten]] ModeStep propose(const GaussianState<NX>& mixed,
                                    const Vector<kMeasurementDim>& z) override {
    predict_without_noise(mixed);
    if (schedule_) {
      pending_distance_ = normalized_distance(z);
      // A plot the model cannot score (NaN, undefined polar point) leaves d unknown: the table's
      // mean multiplier, and the update below reports the plot's status.
      pending_multiplier_ =
          std::isfinite(pending_distance_)
              ? schedule_->process_noise(pending_distance_, pending_distance_ - distance_)
              : schedule_->mean_w();
      if (!std::isfinite(pending_distance_)) pending_distance_ = distance_;
    }
    add_process_noise(pending_multiplier_);
    return update_pending(z);
  }

  /// The prediction alone (a missed plot), with the last step's multiplier.
  ModeStep propose_prediction(const GaussianState<NX>& mixed) override {
    predict_without_noise(mixed);
    pending_distance_ = distance_;
    pending_multiplier_ = multiplier_;
    add_process_noise(multiplier_);
    predicted_ = pending_;
    return {pending_.usable() ? StepStatus::kOk : StepStatus::kNonFiniteResult, 0.0};
  }

  /// Without a schedule: the prediction does not depend on the plot. With one it does (Q is
  /// scaled by the plot's own normalized innovation).
  [[nodiscard]] bool predicts_before_the_plot() const override { return !schedule_; }
  // candidate_innovation and predicted_plot (KalmanModeBase): with a schedule, at the
  // prediction without a plot (the last s), for the gate's predicted plot: the IMM scores
  // candidates by trial updates then.
  /// The held prediction updated with z (ImmMode::propose_update).
  ModeStep propose_update(const Vector<kMeasurementDim>& z) override {
    if (schedule_) return {StepStatus::kInvalidMeasurement, 0.0};
    pending_ = predicted_;
    return update_pending(z);
  }

  /// The mean the motion predicts from the mixed estimate, zero-padded; nothing changes.
  void predicted_mean(const GaussianState<NX>& mixed, Vector<NX>& mean) const override {
    GaussianState<kDim> predicted = embedding_.project(mixed);
    predicted.mean = motion_.mean(predicted.mean);
    SquareMatrix<NX> unused;
    embedding_.embed(predicted, mean, unused);
  }

  /// Makes the pending estimate, d and s current.
  void commit() override {
    estimate_ = pending_;
    distance_ = pending_distance_;
    multiplier_ = pending_multiplier_;
  }

  /// s(k) of the last committed step: how far the schedule moved Q (1 without a schedule).
  [[nodiscard]] double multiplier() const { return multiplier_; }
  /// The table that sets s(k), if any.
  [[nodiscard]] const std::optional<FuzzyRuleTable>& schedule() const { return schedule_; }

 private:
  // The update of pending_ (a prediction with its noise) with z.
  ModeStep update_pending(const Vector<kMeasurementDim>& z) {
    if (!pending_.usable()) return {StepStatus::kNonFiniteResult, 0.0};
    const auto report = iterated_update(pending_, z, measurement_, iterations_);
    this->keep_innovation(report.innovation, report.innovation_covariance);
    return {report.status, report.log_likelihood};
  }

  // pending_ = (f(x̂₀), F P₀ Fᵀ) from the mixed estimate.
  void predict_without_noise(const GaussianState<NX>& mixed) {
    const GaussianState<kDim> prior = embedding_.project(mixed);
    const auto F = motion_.jacobian(prior.mean);
    pending_.mean = motion_.mean(prior.mean);
    pending_.covariance.noalias() = F * prior.covariance * F.transpose();
  }

  // P⁻ = P̄ + s Q (the fixed Q itself without a schedule), symmetrized.
  void add_process_noise(double s) {
    if (schedule_) {
      pending_.covariance += s * motion_.noise();
    } else {
      pending_.covariance += motion_.noise();
    }
    symmetrize(pending_.covariance);
  }

  // d = √(ν̄ᵀ S̄⁻¹ ν̄) at pending_; NaN when the plot or the prediction cannot be scored.
  [[nodiscard]] double normalized_distance(const Vector<kMeasurementDim>& z) const {
    if (!limits::usable_measurement(z) || !measurement_.defined_at(pending_.mean))
      return std::numeric_limits<double>::quiet_NaN();
    const Vector<kMeasurementDim> nu =
        measurement_.residual(z, measurement_.predict(pending_.mean));
    const Matrix<kMeasurementDim, kDim> H = measurement_.jacobian(pending_.mean);
    SquareMatrix<kMeasurementDim> S = H * pending_.covariance * H.transpose();
    S += measurement_.covariance();
    const Eigen::LLT<SquareMatrix<kMeasurementDim>> llt(S);
    if (llt.info() != Eigen::Success) return std::numeric_limits<double>::quiet_NaN();
    return llt.matrixL().solve(nu).norm();
  }

  Motion motion_;
  std::optional<FuzzyRuleTable> schedule_;
  int iterations_ = 1;
  MotionMaker<Motion> maker_;
  double interval_ = 0.0;  // the interval motion_ was last remade for (0: as built)
  GaussianState<kDim> pending_;
  double distance_ = 0.0, pending_distance_ = 0.0;
  double multiplier_ = 1.0, pending_multiplier_ = 1.0;
};

}  // namespace imm
