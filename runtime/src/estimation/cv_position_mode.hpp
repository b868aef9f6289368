// SPDX-License-Identifier: Apache-2.0
#pragma once
// The plain IMM's mode for the common case of surveillance: constant velocity in [x, vx, y, vy]
// with a Cartesian plot. It is KalmanMode<4, 4, PositionMeasurement<4, 2>> with the algebra
// written out (cv_position_algebra.hpp, the TrackBank's per-track arithmetic): F's zeros and ones
// and H's selection are never multiplied, and the covariance is kept as its upper triangle, so it
// is exactly symmetric without averaging. Results differ from the general mode by rounding only
// (tests/runtime/estimation/cv_position_mode_test.cpp). Not installed; build_plain_imm<4> makes it.

#include <array>
#include <string>
#include <string_view>

#include "estimation/cv_position_algebra.hpp"
#include "imm/estimation/imm_mode.hpp"
#include "imm/models/motion/motion_model.hpp"

namespace imm {

/// One constant-velocity mode with a position-selecting measurement (see the file comment).
class CvPositionMode final : public ImmMode<4, 2> {
 public:
  /// `process_noise` is the Q of constant_velocity<2>(sample_period, …); R the plots' covariance.
  /// `maker`, when given, remakes T and Q for other intervals (set_interval).
  CvPositionMode(std::string name, double sample_period, const SquareMatrix<4>& process_noise,
                 const SquareMatrix<2>& measurement_covariance,
                 MotionMaker<LinearMotionModel<4>> maker = {});

  /// Whether a maker was given.
  [[nodiscard]] bool takes_any_interval() const override { return static_cast<bool>(maker_); }
  /// T and Q over `interval` (ImmMode::set_interval).
  bool set_interval(double interval) override;

  [[nodiscard]] std::string_view name() const override { return name_; }
  void embedded_estimate(Vector<4>& mean, SquareMatrix<4>& covariance) const override;
  void reset(const GaussianState<4>& state) override;
  ModeStep propose(const GaussianState<4>& mixed, const Vector<2>& z) override;
  ModeStep propose_prediction(const GaussianState<4>& mixed) override;
  void predicted_mean(const GaussianState<4>& mixed, Vector<4>& mean) const override;
  void commit() override { estimate_ = pending_; }
  /// True: the prediction does not depend on the plot.
  [[nodiscard]] bool predicts_before_the_plot() const override { return true; }
  bool candidate_innovation(const Vector<2>& z, Vector<2>& nu, SquareMatrix<2>& S) const override;
  bool predicted_plot(Vector<2>& z_hat, SquareMatrix<2>& S) const override;
  ModeStep propose_update(const Vector<2>& z) override;

 private:
  using Entries = std::array<double, cv_position::kEntries>;
  static void load(const GaussianState<4>& state, Entries& entries);

  std::string name_;
  double period_ = 1.0;
  std::array<double, cv_position::kTriangle> noise_{};  // Q's upper triangle
  double r00_ = 0.0, r01_ = 0.0, r11_ = 0.0;
  MotionMaker<LinearMotionModel<4>> maker_;
  double interval_ = 0.0;  // the interval period_ and noise_ were last remade for (0: as built)
  void set_noise(const SquareMatrix<4>& process_noise);
  // Predicts the mixed estimate into predicted_; updates predicted_ with z into pending_.
  void predict_mixed(const GaussianState<4>& mixed);
  ModeStep update_predicted(const Vector<2>& z);

  Entries estimate_{};
  Entries pending_{};
  Entries predicted_{};
};

}  // namespace imm
