// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Per-axis filtering, as seed 000 tracks: each Cartesian axis has its own filter (state [p, v],
/// scalar measurement), and TwoAxisFilter puts two of them behind the 2-D TrackFilter interface
/// (state [x, vx, y, vy]; mode probabilities x modes first, then y modes).

#include <Eigen/Core>
#include <memory>
#include <string>

#include "imm/estimation/gaussian_state.hpp"
#include "imm/estimation/imm_estimator.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/imm_track_filter.hpp"
#include "imm/tracking/track_filter.hpp"
#include "imm/tracking/track_options.hpp"

namespace imm {

/// Settings shared by seed 000's per-axis IMMs (eq. 20–21 and the sensor).
struct IMM_RUNTIME_EXPORT AxisImmSettings {
  double sample_period = 0.0;              ///< T, s (unset: from the regime or the model file)
  double measurement_sigma = 0.5;          ///< σ_z per axis (km in seed 000)
  double transition_stay = 0.97;           ///< p_jj of eq. (20); the rest spread evenly
  double initial_first_probability = 0.6;  ///< μ₁(0) of eq. (21); the rest spread evenly

  /// Throws InvalidParameter naming the field.
  void validate() const;
  /// Eq. (20) for n modes (n = 1: [[1]]).
  [[nodiscard]] Eigen::MatrixXd transition(int n) const;
  /// Eq. (21) for n modes (n = 1: [1]).
  [[nodiscard]] Eigen::VectorXd initial_probabilities(int n) const;
  /// Cartesian plots with σ_z² I, two-point initialization.
  [[nodiscard]] TrackOptions track_options(std::int64_t max_gap = kDefaultMaxGap) const;
};

/// log N(ν; 0, S) of a scalar innovation; NaN unless S > 0.
[[nodiscard]] IMM_RUNTIME_EXPORT double axis_log_density(double nu, double variance);
/// log N(ν; 0, S) from ν²/S and log S, axis_log_density's arithmetic (the same bits), for a caller
/// that scores many innovations under one S.
[[nodiscard]] inline double axis_log_density_of(double distance, double log_variance) {
  return -0.5 * (distance + log_variance + kLogTwoPi);
}

/// ImmEstimator::innovation of a one-axis IMM as scalars.
inline bool axis_innovation(const ImmEstimator<2, 1>& imm, double& nu, double& variance) {
  Vector<1> v;
  SquareMatrix<1> s;
  if (!imm.innovation(v, s)) return false;
  nu = v(0);
  variance = s(0, 0);
  return true;
}

/// One Cartesian axis of a track: state [p, v], scalar measurement. TwoAxisFilter runs two of them
/// as a TrackFilter.
class IMM_RUNTIME_EXPORT AxisFilter {
 public:
  AxisFilter() = default;
  AxisFilter(const AxisFilter&) = delete;
  AxisFilter& operator=(const AxisFilter&) = delete;
  virtual ~AxisFilter() = default;

  /// Starts the filter from a Gaussian [p, v].
  virtual void initialize(const GaussianState<2>& state) = 0;
  /// One cycle with the axis measurement z; any status other than kOk leaves the filter as it was.
  virtual StepStatus step(double z) = 0;
  /// One cycle without a measurement; any status other than kOk leaves the filter as it was.
  virtual StepStatus predict_only() = 0;
  /// The combined [p, v] estimate.
  [[nodiscard]] virtual const GaussianState<2>& estimate() const = 0;
  /// The mode probabilities, in mode order (one entry for a single-model filter).
  [[nodiscard]] virtual ModeVector mode_probabilities() const = 0;
  /// The number of modes.
  [[nodiscard]] virtual int mode_count() const = 0;
  /// The name of mode j (0-based).
  [[nodiscard]] virtual std::string mode_name(int j) const = 0;
  /// The last cycle's innovation and its variance (TrackFilter::innovation, one axis); false
  /// unless the last call was a successful step().
  virtual bool innovation(double& nu, double& variance) const = 0;
  /// log p(z | Z^(k−1)) of the last step's plot (TrackFilter::log_predictive_likelihood, one
  /// axis); the default is log N(ν; 0, S) of innovation(), NaN without one.
  [[nodiscard]] virtual double log_predictive_likelihood() const;

  // The cycle in two halves, one axis (TrackFilter::predict and what follows it). The defaults:
  // no split (has_split_cycle() false; predict(), update() and miss() throw std::logic_error,
  // the candidate questions answer NaN or false).

  /// Whether predict(), update() and miss() work.
  [[nodiscard]] virtual bool has_split_cycle() const { return false; }
  /// Whether the prediction does not depend on the measurement.
  [[nodiscard]] virtual bool predicts_before_the_plot() const { return false; }
  /// The first half: the prediction held until update() or miss().
  virtual StepStatus predict();
  /// After predict(): log p(z | past) of a candidate axis measurement; nothing changes.
  [[nodiscard]] virtual double candidate_log_likelihood(double z) const;
  /// After predict(): ν²/S of a candidate (the collapsed mixture's, for an IMM); nothing changes.
  [[nodiscard]] virtual double candidate_distance(double z) const;
  /// After predict(): the predicted measurement and its variance.
  virtual bool predicted_plot(double& z_hat, double& variance) const;
  /// The second half with z: step(z)'s numbers.
  virtual StepStatus update(double z);
  /// The second half without a measurement: predict_only()'s numbers.
  virtual StepStatus miss();
};

/// An IMM over per-axis modes (filters with per-mode extras derive from it); what does not depend
/// on the plot's type is ImmForwarding's (imm_track_filter.hpp).
class IMM_RUNTIME_EXPORT ImmAxisFilter : public ImmForwarding<AxisFilter, 2, 1> {
 public:
  /// Takes an IMM of axis modes.
  explicit ImmAxisFilter(ImmEstimator<2, 1> from) : ImmForwarding(std::move(from)) {}

  /// Starts every mode from `state`; the mode probabilities restart at the initial ones.
  void initialize(const GaussianState<2>& state) override { estimator().initialize(state); }
  StepStatus step(double z) override { return estimator().step(Vector<1>(z)); }
  /// The IMM's combined estimate.
  [[nodiscard]] const GaussianState<2>& estimate() const override { return imm().estimate(); }
  /// The name of IMM mode j.
  [[nodiscard]] std::string mode_name(int j) const override {
    return std::string(imm().mode(j).name());
  }
  /// The IMM's combined innovation.
  bool innovation(double& nu, double& variance) const override {
    return axis_innovation(imm(), nu, variance);
  }
  /// ImmEstimator::candidate_log_likelihood.
  [[nodiscard]] double candidate_log_likelihood(double z) const override {
    return imm().candidate_log_likelihood(Vector<1>(z));
  }
  /// ImmEstimator::candidate_distance.
  [[nodiscard]] double candidate_distance(double z) const override {
    return imm().candidate_distance(Vector<1>(z));
  }
  /// ImmEstimator::predicted_plot.
  bool predicted_plot(double& z_hat, double& variance) const override;
  /// ImmEstimator::update.
  StepStatus update(double z) override { return estimator().update(Vector<1>(z)); }
};

/// Two axis filters as one 2-D filter. A plot is validated before either axis moves; a numerical
/// failure of the y axis after x succeeded (impossible for finite estimates with R > 0) is
/// reported, with x already advanced.
class IMM_RUNTIME_EXPORT TwoAxisFilter final : public TrackFilter {
 public:
  /// Takes the x and y axis filters (neither null).
  TwoAxisFilter(std::unique_ptr<AxisFilter> x, std::unique_ptr<AxisFilter> y);

  /// 4: [x, vx, y, vy].
  [[nodiscard]] int state_dimension() const override { return 4; }
  /// The x modes plus the y modes.
  [[nodiscard]] int mode_count() const override { return x_->mode_count() + y_->mode_count(); }
  /// "x.<name>" for the x modes, then "y.<name>".
  [[nodiscard]] std::string mode_name(int j) const override;
  void initialize(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) override;
  StepStatus step(const Eigen::Vector2d& z) override;
  StepStatus predict_only() override;
  void state(Eigen::Ref<Eigen::VectorXd> mean, Eigen::Ref<Eigen::VectorXd> variance) const override;
  void covariance(Eigen::Ref<Eigen::MatrixXd> covariance) const override;
  /// The x axis's mode probabilities followed by the y axis's.
  [[nodiscard]] ModeVector mode_probabilities() const override;
  /// [ν_x, ν_y] with S = diag(S_x, S_y): the axes are independent filters.
  bool innovation(Eigen::Vector2d& nu, Eigen::Matrix2d& S) const override;
  /// The sum of the axes' (independent filters).
  [[nodiscard]] double log_predictive_likelihood() const override {
    return x_->log_predictive_likelihood() + y_->log_predictive_likelihood();
  }
  /// Where both axes split theirs (AxisFilter::has_split_cycle).
  [[nodiscard]] bool has_split_cycle() const override {
    return x_->has_split_cycle() && y_->has_split_cycle();
  }
  /// Where both axes predict before the plot.
  [[nodiscard]] bool predicts_before_the_plot() const override {
    return x_->predicts_before_the_plot() && y_->predicts_before_the_plot();
  }
  /// Both axes predict (x first; a failure of y leaves x's prediction held).
  StepStatus predict() override;
  /// The sum of the axes' (independent filters).
  [[nodiscard]] double candidate_log_likelihood(const Eigen::Vector2d& z) const override {
    return x_->candidate_log_likelihood(z(0)) + y_->candidate_log_likelihood(z(1));
  }
  /// The sum of the axes' ν²/S: νᵀ S⁻¹ ν with S = diag(S_x, S_y), as innovation().
  [[nodiscard]] double candidate_distance(const Eigen::Vector2d& z) const override {
    return x_->candidate_distance(z(0)) + y_->candidate_distance(z(1));
  }
  /// [ẑ_x, ẑ_y] and diag(S_x, S_y).
  bool predicted_plot(Eigen::Vector2d& z_hat, Eigen::Matrix2d& S) const override;
  /// The plot is validated first, then x and y update, as step().
  StepStatus update(const Eigen::Vector2d& z) override;
  /// Both axes without a plot.
  StepStatus miss() override;

  /// Axis 0 (x) or 1 (y).
  [[nodiscard]] const AxisFilter& axis(int i) const { return i == 0 ? *x_ : *y_; }

 private:
  // `call(axis, index)` on x, then on y unless x's status was not kOk (which is returned, x
  // already moved: see the class comment).
  template <class Call>
  StepStatus x_then_y(Call&& call) {
    const StepStatus status = call(*x_, Eigen::Index{0});
    return status == StepStatus::kOk ? call(*y_, Eigen::Index{1}) : status;
  }

  std::unique_ptr<AxisFilter> x_;
  std::unique_ptr<AxisFilter> y_;
};

}  // namespace imm
