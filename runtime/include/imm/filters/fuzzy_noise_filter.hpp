// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The fuzzy-noise Kalman filter of seed 000 §3.2 for one axis, state [p, v], H = [1 0]:
///   x̂⁻ = F x̂₀                                           (19-1)
///   r(k) = z(k) − H x̂⁻,  Δr(k) = r(k) − r(k−1)           (19-3, 19-4)
///   q(k) = table(r, Δr)                                   (19-5)
///   P⁻ = F P₀ Fᵀ + G q(k) Gᵀ                              (19-6)
///   then the Kalman update with innovation r(k)           (19-7 … 19-10, Joseph form here)
/// The same step serves the runtime's IMM mode and the trainer's fitness (train what you deploy).
/// r(k−1) is the filter's own previous residual; a new track starts with r(−1) = 0.
///
/// Antecedents (FuzzyAntecedents): the seed's table reads the raw residual r and its change Δr, in
/// measurement units, so a table learned at one plot σ means something else at another. With
/// kNormalizedInnovation it reads ñ = r/√S̄ and Δñ = ñ(k) − ñ(k−1) instead, S̄ = H F P₀ Fᵀ Hᵀ + R
/// the innovation variance before this step's process noise (the noise the table sets cannot be
/// inside its own input). ñ is dimensionless and about N(0, 1) while the mode fits the target, so
/// one table reads alike at any σ, unit and sample period; only its consequents w carry units.

#include <cmath>
#include <string>
#include <string_view>
#include <utility>

#include "imm/core/checks.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/estimation/imm_mode.hpp"
#include "imm/estimation/kalman_filter.hpp"
#include "imm/filters/fuzzy_noise_step.hpp"
#include "imm/models/learned/fuzzy_rule_table.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// "residual" or "normalized_innovation" (configs and model files).
[[nodiscard]] IMM_RUNTIME_EXPORT std::string_view to_string(FuzzyAntecedents antecedents);
/// The antecedents named `name`; InvalidParameter(field) listing the names otherwise.
[[nodiscard]] IMM_RUNTIME_EXPORT FuzzyAntecedents fuzzy_antecedents_from(std::string_view name,
                                                                         const std::string& field);

/// The fuzzy-noise Kalman filter of one axis (see the file comment).
class IMM_RUNTIME_EXPORT FuzzyNoiseFilter {
 public:
  /// What one step did.
  struct Step {
    /// kOk, or why the state was left unchanged.
    StepStatus status = StepStatus::kOk;
    /// The table's first input: r(k), or r(k)/√S̄ with normalized antecedents. The next step's
    /// `previous` (its change is the second input).
    double antecedent = 0.0;
    double residual = 0.0;             ///< r(k)
    double process_noise = 0.0;        ///< q(k)
    double innovation_variance = 0.0;  ///< S(k) = H P⁻ Hᵀ + R with q(k)
    /// log N(r; 0, S) of the innovation.
    double log_likelihood = 0.0;
  };

  /// Throws InvalidParameter naming the field: a non-positive sample period or measurement
  /// variance.
  FuzzyNoiseFilter(FuzzyRuleTable table, double sample_period, double measurement_variance,
                   FuzzyAntecedents antecedents = FuzzyAntecedents::kResidual)
      : table_(std::move(table)),
        antecedents_(antecedents),
        F_(cv_axis_transition(sample_period)),
        G_(cv_axis_input_gain(sample_period)),
        R_(SquareMatrix<1>::Constant(measurement_variance)) {
    require_positive(sample_period, "sample_period");
    require_positive(measurement_variance, "measurement_variance");
    GGt_ = G_ * G_.transpose();
    H_ << 1.0, 0.0;
    axis_ = lanes::FuzzyAxisConstants(sample_period, measurement_variance, antecedents);
  }

  /// Predicts `state` one period and updates it with z; on failure `state` is unchanged.
  /// `previous` is the last step's Step::antecedent (0 on a new track). The step is
  /// lanes::fuzzy_noise_step for a double, the one the banks and the GA fitness batch run over
  /// packs.
  Step step(GaussianState<2>& state, double previous, double z) const {
    Step result;
    if (!limits::usable_measurement(z)) {
      result.status = StepStatus::kInvalidMeasurement;
      return result;
    }
    const lanes::FuzzyNoiseStep<double> s =
        lanes::fuzzy_noise_step<double>(axis_, lanes::FuzzyTableRules(table_), z, previous,
                                        {state.mean(0), state.mean(1), state.covariance(0, 0),
                                         state.covariance(0, 1), state.covariance(1, 1)});
    result.antecedent = s.antecedent;
    result.residual = s.residual;
    result.process_noise = s.process_noise;
    result.innovation_variance = s.s;
    if (!s.usable) {
      result.status = StepStatus::kSingularInnovation;
      return result;
    }
    if (!s.finite) {
      result.status = StepStatus::kNonFiniteResult;
      return result;
    }
    result.log_likelihood = -0.5 * (s.mahalanobis + std::log(s.s) + kLogTwoPi);
    state.mean << s.estimate.x0, s.estimate.x1;
    state.covariance << s.estimate.p00, s.estimate.p01, s.estimate.p01, s.estimate.p11;
    return result;
  }

  /// Prediction without a measurement, with the table's mean w as q.
  [[nodiscard]] GaussianState<2> predict_only(const GaussianState<2>& state) const {
    return predict(state, F_, SquareMatrix<2>(table_.mean_w() * GGt_));
  }

  /// The rule table that sets q(k).
  [[nodiscard]] const FuzzyRuleTable& table() const { return table_; }
  /// What the table reads.
  [[nodiscard]] FuzzyAntecedents antecedents() const { return antecedents_; }
  /// F of the CV model.
  [[nodiscard]] const SquareMatrix<2>& transition() const { return F_; }
  /// H = [1, 0].
  [[nodiscard]] const Matrix<1, 2>& measurement_matrix() const { return H_; }
  /// R = σ_z².
  [[nodiscard]] const SquareMatrix<1>& measurement_noise() const { return R_; }

 private:
  FuzzyRuleTable table_;
  FuzzyAntecedents antecedents_ = FuzzyAntecedents::kResidual;
  SquareMatrix<2> F_;
  Vector<2> G_;
  SquareMatrix<2> GGt_;
  Matrix<1, 2> H_;
  SquareMatrix<1> R_;
  lanes::FuzzyAxisConstants axis_;  // T, R, G Gᵀ and the antecedents, for the step
};

/// The fuzzy-noise KF as an IMM mode (seed 000's sub-model m_j, eq. 18–19).
class IMM_RUNTIME_EXPORT FuzzyNoiseMode final : public ImmMode<2, 1> {
 public:
  /// A named mode of `filter`.
  FuzzyNoiseMode(std::string name, FuzzyNoiseFilter filter)
      : name_(std::move(name)), filter_(std::move(filter)) {}

  [[nodiscard]] std::string_view name() const override { return name_; }

  /// The current estimate (the mixing space is the filter's).
  void embedded_estimate(Vector<2>& mean, SquareMatrix<2>& covariance) const override {
    mean = estimate_.mean;
    covariance = estimate_.covariance;
  }

  /// Sets the estimate and clears the previous residual.
  void reset(const GaussianState<2>& state) override {
    estimate_ = state;
    antecedent_ = 0.0;
    process_noise_ = filter_.table().mean_w();
  }

  /// One fuzzy-noise step from `mixed` with z; pending until commit().
  ModeStep propose(const GaussianState<2>& mixed, const Vector<1>& z) override {
    pending_ = mixed;
    const FuzzyNoiseFilter::Step step = filter_.step(pending_, antecedent_, z(0));
    pending_antecedent_ = step.antecedent;
    pending_process_noise_ = step.process_noise;
    keep_innovation(Vector<1>(step.residual), SquareMatrix<1>(step.innovation_variance));
    return {step.status, step.log_likelihood};
  }

  /// Prediction from `mixed` with the table's mean w; pending until commit().
  ModeStep propose_prediction(const GaussianState<2>& mixed) override {
    pending_ = filter_.predict_only(mixed);
    pending_antecedent_ = antecedent_;
    pending_process_noise_ = filter_.table().mean_w();
    return {pending_.all_finite() ? StepStatus::kOk : StepStatus::kNonFiniteResult, 0.0};
  }

  /// F times the mixed mean.
  void predicted_mean(const GaussianState<2>& mixed, Vector<2>& mean) const override {
    mean = filter_.transition() * mixed.mean;
  }

  /// After propose_prediction(): ν and S of a candidate plot at the prediction without a plot
  /// (the table's mean w); the IMM scores candidates by trial updates, this is for the gate's
  /// predicted plot.
  bool candidate_innovation(const Vector<1>& z, Vector<1>& nu, SquareMatrix<1>& S) const override {
    return score_candidate(pending_, z, filter_.measurement_matrix(), filter_.measurement_noise(),
                           nu, S);
  }
  /// After propose_prediction(): ẑ and S of the prediction without a plot.
  bool predicted_plot(Vector<1>& z_hat, SquareMatrix<1>& S) const override {
    return predict_plot(pending_, filter_.measurement_matrix(), filter_.measurement_noise(), z_hat,
                        S);
  }

  void commit() override {
    estimate_ = pending_;
    antecedent_ = pending_antecedent_;
    process_noise_ = pending_process_noise_;
  }

  /// q(k) of the last committed step: how much the table adapts.
  [[nodiscard]] double process_noise() const { return process_noise_; }
  /// The underlying filter.
  [[nodiscard]] const FuzzyNoiseFilter& filter() const { return filter_; }

 private:
  std::string name_;
  FuzzyNoiseFilter filter_;
  GaussianState<2> estimate_;
  GaussianState<2> pending_;
  double antecedent_ = 0.0;  // the table's first input at the last committed step
  double pending_antecedent_ = 0.0;
  double process_noise_ = 0.0;
  double pending_process_noise_ = 0.0;
};

}  // namespace imm
