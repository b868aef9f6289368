// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// A bank whose tracks state their covariances through a model file's covariance calibration:
/// the multi-track form of CalibratedFilter (imm/tracking/calibrated_filter.hpp), so that a bank
/// opened from a calibrated model gates and reports as its one-track filters do.
///
/// Per track it keeps the calibration's two features, the plots used since the start and the
/// exponentially weighted NIS level, and follows them from the NIS the wrapped bank states for
/// each step. The estimate's covariance is scaled by the state factor, the gate by the innovation
/// factor (a pair is inside where distance / factor ≤ gate, CalibratedFilter::candidate_distance);
/// the means, the mode probabilities and the log-likelihoods are the wrapped bank's. Nothing is
/// allocated per step.

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <span>
#include <vector>

#include "imm/model_kinds.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/calibrated_filter.hpp"

namespace imm {

/// A track bank through a covariance calibration (see the file comment).
class IMM_RUNTIME_EXPORT CalibratedTrackBank final : public AnyTrackBank {
 public:
  /// Wraps `bank` (not null, and states_step_nis(): InvalidParameter("bank") otherwise) with
  /// `calibration` (not null: InvalidParameter("calibration"); validated).
  CalibratedTrackBank(std::unique_ptr<AnyTrackBank> bank,
                      std::shared_ptr<const CovarianceCalibration> calibration);

  [[nodiscard]] std::size_t capacity() const override { return bank_->capacity(); }
  [[nodiscard]] int state_dimension() const override { return bank_->state_dimension(); }
  /// Starts a track as the wrapped bank does; its features start over (no plot used, level 2).
  void initialize(std::size_t track, const Eigen::VectorXd& mean,
                  const Eigen::MatrixXd& covariance) override;
  /// The wrapped bank's step; each track stepped with status kOk counts one plot more and takes
  /// its NIS into its level (CalibratedFilter::step).
  void step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status) override;
  /// step(), with each track's NIS (the model's own, which the level follows).
  void step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status,
            std::span<double> nis) override;
  [[nodiscard]] bool initialized(std::size_t track) const override {
    return bank_->initialized(track);
  }
  /// The wrapped bank's estimate, its covariance scaled by the track's state factor.
  void estimate(std::size_t track, Eigen::VectorXd& mean,
                Eigen::MatrixXd& covariance) const override;
  [[nodiscard]] ModeVector mode_probabilities(std::size_t track) const override {
    return bank_->mode_probabilities(track);
  }
  /// The wrapped bank's log-likelihoods, each track gated at gate × its innovation factor: the
  /// entries CalibratedFilter's candidate_log_likelihood and candidate_distance give.
  void candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots, double gate,
                                 Eigen::Ref<Eigen::MatrixXd> out) override;
  /// The same with gate_scale[t] on top of the track's innovation factor.
  void candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots, double gate,
                                 std::span<const double> gate_scale,
                                 Eigen::Ref<Eigen::MatrixXd> out) override;
  bool set_interval(double interval) override { return bank_->set_interval(interval); }
  [[nodiscard]] bool states_step_nis() const override { return true; }
  [[nodiscard]] const CovarianceCalibration* calibration() const override {
    return calibration_.get();
  }

  /// A track's features: plots used since its start and its NIS level (CalibratedFilter's).
  [[nodiscard]] long plots_used(std::size_t track) const;
  [[nodiscard]] double nis_level(std::size_t track) const;  ///< (see plots_used)
  /// A track's factors of S and of P for its next cycle (CalibratedFilter's after predict()).
  [[nodiscard]] double innovation_scale(std::size_t track) const;
  [[nodiscard]] double state_scale(std::size_t track) const;  ///< (see innovation_scale)
  /// The bank wrapped.
  [[nodiscard]] AnyTrackBank& inner() { return *bank_; }

 private:
  [[nodiscard]] std::size_t checked(std::size_t track) const;
  void follow(std::span<const StepStatus> status, std::span<const double> nis);

  std::unique_ptr<AnyTrackBank> bank_;
  std::shared_ptr<const CovarianceCalibration> calibration_;
  std::vector<long> used_;
  std::vector<double> level_;
  std::vector<double> nis_;    // step()'s NIS, kept for the call without one
  std::vector<double> scale_;  // the gating's factors per track
};

}  // namespace imm
