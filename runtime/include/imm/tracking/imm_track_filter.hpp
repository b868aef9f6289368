// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// A TrackFilter that is one ImmEstimator of plots in two coordinates: every question the
/// interface asks is answered by the IMM (imm_estimator.hpp), the split cycle included. A filter
/// family (the FIMM, the wIMM) derives from it with its modes, its mode names and whatever it does
/// besides, and overrides only that. What does not depend on the plot's type is ImmForwarding,
/// which the one-axis IMM (ImmAxisFilter, axis_filter.hpp) shares.

#include <Eigen/Core>
#include <utility>

#include "imm/estimation/imm_estimator.hpp"
#include "imm/tracking/track_filter.hpp"

namespace imm {

/// The answers of a filter interface (TrackFilter, AxisFilter) that an ImmEstimator<NX, NZ> gives
/// whatever a plot is: its modes, the cycle without a plot, the split cycle's halves and the
/// predictive likelihood. The interface's plot-typed calls (step, update, the candidate
/// questions, innovation) are the deriving filter's.
template <class Interface, int NX, int NZ>
class ImmForwarding : public Interface {
 public:
  /// The IMM's.
  [[nodiscard]] int mode_count() const override { return imm_.mode_count(); }
  /// ImmEstimator::predict_only.
  StepStatus predict_only() override { return imm_.predict_only(); }
  /// μ_j in the IMM's mode order.
  [[nodiscard]] ModeVector mode_probabilities() const override { return imm_.mode_probabilities(); }
  /// The IMM's mixture log Σ_j c_j N(ν_j; 0, S_j).
  [[nodiscard]] double log_predictive_likelihood() const override {
    return imm_.log_predictive_likelihood();
  }
  /// The IMM's split cycle (ImmEstimator::predict and what follows it).
  [[nodiscard]] bool has_split_cycle() const override { return true; }
  /// Whether every mode predicts before the plot (no trial updates).
  [[nodiscard]] bool predicts_before_the_plot() const override {
    return imm_.predicts_before_the_plot();
  }
  /// ImmEstimator::predict.
  StepStatus predict() override { return imm_.predict(); }
  /// ImmEstimator::miss.
  StepStatus miss() override { return imm_.miss(); }

  /// The underlying IMM.
  [[nodiscard]] const ImmEstimator<NX, NZ>& imm() const { return imm_; }

 protected:
  /// A filter that is the IMM `from`.
  explicit ImmForwarding(ImmEstimator<NX, NZ> from) : imm_(std::move(from)) {}

  /// The IMM to change, for what a family does besides.
  [[nodiscard]] ImmEstimator<NX, NZ>& estimator() { return imm_; }

 private:
  ImmEstimator<NX, NZ> imm_;
};

/// The TrackFilter of an ImmEstimator<NX, 2> (see the file comment).
template <int NX>
class ImmTrackFilter : public ImmForwarding<TrackFilter, NX, 2> {
  using Base = ImmForwarding<TrackFilter, NX, 2>;

 public:
  using Base::imm;

  /// NX.
  [[nodiscard]] int state_dimension() const override { return NX; }
  /// Starts every mode from (mean, covariance). Throws InvalidParameter("initial_state") for a
  /// mean that is not NX finite numbers, ("initial_covariance") for a covariance that is not NX ×
  /// NX, finite and symmetric with a non-negative diagonal.
  void initialize(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) override {
    require_initial_state(mean, covariance, NX);
    GaussianState<NX> state;
    state.mean = mean;
    state.covariance = covariance;
    this->estimator().initialize(state);
  }
  /// ImmEstimator::step.
  StepStatus step(const Eigen::Vector2d& z) override { return this->estimator().step(z); }
  // Eigen::Ref by value is the interface's (track_filter.hpp).
  // NOLINTBEGIN(performance-unnecessary-value-param)
  /// The combined estimate's mean and variances.
  void state(Eigen::Ref<Eigen::VectorXd> mean,
             Eigen::Ref<Eigen::VectorXd> variance) const override {
    mean = imm().estimate().mean;
    variance = imm().estimate().covariance.diagonal();
  }
  /// The combined estimate's covariance.
  void covariance(Eigen::Ref<Eigen::MatrixXd> covariance) const override {
    covariance = imm().estimate().covariance;
  }
  // NOLINTEND(performance-unnecessary-value-param)
  /// The IMM's combined innovation (ImmEstimator::innovation).
  bool innovation(Eigen::Vector2d& nu, Eigen::Matrix2d& S) const override {
    return imm().innovation(nu, S);
  }
  /// ImmEstimator::candidate_log_likelihood.
  [[nodiscard]] double candidate_log_likelihood(const Eigen::Vector2d& z) const override {
    return imm().candidate_log_likelihood(z);
  }
  /// ImmEstimator::candidate_distance.
  [[nodiscard]] double candidate_distance(const Eigen::Vector2d& z) const override {
    return imm().candidate_distance(z);
  }
  /// ImmEstimator::predicted_plot.
  bool predicted_plot(Eigen::Vector2d& z_hat, Eigen::Matrix2d& S) const override {
    return imm().predicted_plot(z_hat, S);
  }
  /// ImmEstimator::update.
  StepStatus update(const Eigen::Vector2d& z) override { return this->estimator().update(z); }

  /// The combined estimate with its full covariance.
  [[nodiscard]] const GaussianState<NX>& estimate() const { return imm().estimate(); }

 protected:
  /// A filter that is the IMM `from`.
  explicit ImmTrackFilter(ImmEstimator<NX, 2> from) : Base(std::move(from)) {}
};

}  // namespace imm
