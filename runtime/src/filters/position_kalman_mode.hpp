// SPDX-License-Identifier: Apache-2.0
#pragma once
// The one-track mode of the weighted IMM and of the FIMM: a Kalman mode of D states per axis in
// the 6-state mixing space whose step is position_kalman_step.hpp's over one lane — the banks run
// the same step over their blocks. `Measure` says how the plot is measured:
//   linearize(z, mode, g)  the linearization at the mode's prediction (H's position columns, R,
//                          ν of plot z, ẑ, whether h is defined there)
//   update(z, mode)        the mode's update of its prediction with plot z (update_mode after
//                          linearize, or an iterated update)
// Not installed.

#include <string>
#include <string_view>
#include <utility>

#include "filters/position_kalman_step.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/estimation/imm_mode.hpp"

namespace imm {

/// A Kalman mode of D states per axis measured through `Measure` (see the file comment).
template <int D, class Measure>
class PositionKalmanMode final : public ImmMode<6, 2> {
 public:
  /// The mode's own state dimension.
  static constexpr int kDim = 2 * D;

  /// A mode named `name` with motion `model` (one axis block of F and Q).
  PositionKalmanMode(std::string name, const bank::AxisModel& model, Measure measure)
      : name_(std::move(name)), model_(model), measure_(std::move(measure)) {}

  [[nodiscard]] std::string_view name() const override { return name_; }

  void embedded_estimate(Vector<6>& mean, SquareMatrix<6>& covariance) const override {
    mean.setZero();
    covariance.setZero();
    for (int i = 0; i < kDim; ++i) {
      const int a = bank::mixing_index(D, i);
      mean(a) = estimate_.mean(i);
      for (int k = 0; k < kDim; ++k)
        covariance(a, bank::mixing_index(D, k)) = estimate_.covariance(i, k);
    }
  }

  void reset(const GaussianState<6>& state) override {
    project(
        state, [&](int i) -> double& { return estimate_.mean(i); },
        [&](int i, int k) -> double& { return estimate_.covariance(i, k); });
  }

  /// The prediction updated with z; a prediction that is not finite fails in the update (an S
  /// that is not finite), as a bank's lane does.
  ModeStep propose(const GaussianState<6>& mixed, const Vector<2>& z) override {
    predict_from(mixed);
    return propose_update(z);
  }

  /// The prediction, held for propose_update() and committed as it is by a cycle without a plot.
  ModeStep propose_prediction(const GaussianState<6>& mixed) override {
    predict_from(mixed);
    restore_prediction();
    double zero = 0.0;  // x * 0 is 0 for a finite x and NaN otherwise
    for (int i = 0; i < kDim; ++i) {
      zero += step_.x[i][0] * 0.0;
      for (int k = 0; k < kDim; ++k) zero += step_.P[i][k][0] * 0.0;
    }
    return {zero == 0.0 ? StepStatus::kOk : StepStatus::kNonFiniteResult, 0.0};
  }

  /// True: the prediction does not depend on the plot.
  [[nodiscard]] bool predicts_before_the_plot() const override { return true; }

  /// The held prediction updated with z.
  ModeStep propose_update(const Vector<2>& z) override {
    if (!limits::usable_measurement(z)) return {StepStatus::kInvalidMeasurement, 0.0};
    measure_.update(z, step_);
    kept_innovation() << step_.nu[0][0], step_.nu[1][0];
    kept_innovation_covariance() << step_.s[0][0], step_.s[1][0], step_.s[1][0], step_.s[2][0];
    const StepStatus status = bank::status_of(step_.code[0]);
    if (status != StepStatus::kOk) {  // a later commit keeps the prediction, as a coast would
      restore_prediction();
      return {status, 0.0};
    }
    return {status, step_.log_likelihood[0]};
  }

  void predicted_mean(const GaussianState<6>& mixed, Vector<6>& mean) const override {
    double own[kDim][1], predicted[kDim][1];
    for (int i = 0; i < kDim; ++i) own[i][0] = mixed.mean(bank::mixing_index(D, i));
    bank::predict_mean<D, 1>(model_, own, predicted);
    mean.setZero();
    for (int i = 0; i < kDim; ++i) mean(bank::mixing_index(D, i)) = predicted[i][0];
  }

  bool candidate_innovation(const Vector<2>& z, Vector<2>& nu, SquareMatrix<2>& S) const override {
    if (!limits::usable_measurement(z)) return false;
    bank::Linearization<1> g;  // NOLINT(cppcoreguidelines-pro-type-member-init): written first
    if (!linearize(z, g, S)) return false;
    nu << g.nu0[0], g.nu1[0];
    return true;
  }

  bool predicted_plot(Vector<2>& z_hat, SquareMatrix<2>& S) const override {
    bank::Linearization<1> g;  // NOLINT(cppcoreguidelines-pro-type-member-init): written first
    if (!linearize(Vector<2>::Zero(), g, S)) return false;
    z_hat << g.z_hat0[0], g.z_hat1[0];
    return true;
  }

  void commit() override {
    for (int i = 0; i < kDim; ++i) {
      estimate_.mean(i) = step_.xu[i][0];
      for (int k = 0; k < kDim; ++k) estimate_.covariance(i, k) = step_.U[i][k][0];
    }
  }

  /// The mode's current estimate in its own states.
  [[nodiscard]] const GaussianState<kDim>& estimate() const { return estimate_; }

 private:
  // The mode's states of a mixing-space Gaussian: mean(i) and covariance(i, k) take them.
  template <class Mean, class Covariance>
  static void project(const GaussianState<6>& state, Mean&& mean, Covariance&& covariance) {
    for (int i = 0; i < kDim; ++i) {
      const int a = bank::mixing_index(D, i);
      mean(i) = state.mean(a);
      for (int k = 0; k < kDim; ++k)
        covariance(i, k) = state.covariance(a, bank::mixing_index(D, k));
    }
  }

  // Predicts from a mixed condition into the held prediction.
  void predict_from(const GaussianState<6>& mixed) {
    double mean[kDim][1], covariance[kDim][kDim][1];
    project(
        mixed, [&](int i) -> double& { return mean[i][0]; },
        [&](int i, int k) -> double& { return covariance[i][k][0]; });
    bank::predict<D, 1>(model_, mean, covariance, step_);
  }

  // The linearization at the held prediction and S there; false where h is undefined.
  bool linearize(const Vector<2>& z, bank::Linearization<1>& g, SquareMatrix<2>& S) const {
    measure_.linearize(z, step_, g);
    if (g.defined[0] == 0.0) return false;
    double pht[kDim][2][1], s[3][1];
    bank::innovation_covariance<D, 1>(g, step_.P, pht, s);
    S << s[0][0], s[1][0], s[1][0], s[2][0];
    return true;
  }

  // The pending estimate becomes the held prediction.
  void restore_prediction() {
    for (int i = 0; i < kDim; ++i) {
      step_.xu[i][0] = step_.x[i][0];
      for (int k = 0; k < kDim; ++k) step_.U[i][k][0] = step_.P[i][k][0];
    }
  }

  std::string name_;
  bank::AxisModel model_;
  Measure measure_;
  GaussianState<kDim> estimate_;
  bank::ModeLanes<D, 1> step_{};  // the held prediction and the pending update
};

}  // namespace imm
