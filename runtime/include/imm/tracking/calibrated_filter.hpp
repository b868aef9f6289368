// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// A covariance calibration learned on a model's training split, stored in its file
/// (`/calibration`) and applied by the runtime to what a tracker gates and reports with.
///
/// An IMM's moment-matched innovation covariance S and state covariance P are not exactly its
/// errors' covariances: after a two-point start they are too large for a while, at a manoeuvre's
/// onset too small. A single factor cannot fix both (docs/results.md). The calibration scales them
/// by a factor that depends on what the track has seen,
///
///   c = start[min(u, n_start − 1)] · level[bin(ℓ)],
///
/// where u counts the plots used since the track started and ℓ is an exponentially weighted mean
/// of the track's own past normalized innovations squared (memory λ, each capped at `nis_cap`):
/// ℓ ← λ ℓ + (1 − λ) min(NIS, cap), starting at the plot dimension 2. `edges` cut ℓ into the
/// bins of `level`. One pair of tables scales S (the gate's distance, predicted_plot, innovation),
/// another scales P (state, covariance). The filter's own estimate, gain and mode probabilities
/// are unchanged, and so are the likelihoods (the model's own predictive density): a calibrated
/// filter tracks exactly as the model does and states its uncertainty as it turned out to be.

#include <memory>
#include <string>
#include <vector>

#include "imm/runtime_export.hpp"
#include "imm/tracking/track_filter.hpp"

namespace imm {

namespace io {
class ModelFileReader;
}

/// The model-file schema version that holds `/calibration` (docs/model-schema.md).
inline constexpr int kCalibrationSchemaVersion = 4;

/// The calibration's tables (see the file comment).
struct IMM_RUNTIME_EXPORT CovarianceCalibration {
  /// The most entries a table may have.
  static constexpr int kMaxEntries = 256;
  /// λ of the NIS level, in [0, 1).
  double memory = 0.7;
  /// The largest NIS one plot adds to the level (> 0).
  double nis_cap = 50.0;
  /// Factors of S by plots used since the start; the last one holds on. Non-empty.
  std::vector<double> start_innovation{1.0};
  /// Factors of P likewise (as many as start_innovation).
  std::vector<double> start_state{1.0};
  /// Ascending bin edges of the NIS level (may be empty: one bin).
  std::vector<double> edges{};
  /// Factors of S per bin of the level: edges.size() + 1.
  std::vector<double> level_innovation{1.0};
  /// Factors of P per bin of the level: edges.size() + 1.
  std::vector<double> level_state{1.0};

  /// Throws InvalidParameter naming "calibration.<field>" (or an entry of it) for sizes that do not
  /// fit, factors not finite and > 0, edges not finite and strictly ascending.
  void validate() const;
  /// The factor of S for a track after `used` plots with NIS level `level`.
  [[nodiscard]] double innovation_scale(long used, double level) const noexcept;
  /// The factor of P likewise.
  [[nodiscard]] double state_scale(long used, double level) const noexcept;
  /// The bin of `level` (0 … edges.size()).
  [[nodiscard]] int bin(double level) const noexcept;
  /// The NIS level after a step of NIS `nis`: memory · level + (1 − memory) · min(nis, nis_cap).
  [[nodiscard]] double next_level(double level, double nis) const noexcept;
};

/// The calibration a model file carries (`/calibration`), or nothing. Throws io::FileError naming
/// the field for an invalid one.
[[nodiscard]] IMM_RUNTIME_EXPORT std::shared_ptr<const CovarianceCalibration> read_calibration(
    const io::ModelFileReader& reader);

/// A filter whose S and P are calibrated (see the file comment); every other answer is the wrapped
/// filter's. Allocation-free per cycle.
class IMM_RUNTIME_EXPORT CalibratedFilter final : public TrackFilter {
 public:
  /// Wraps `filter` (not null) with `calibration` (not null; validated).
  CalibratedFilter(std::unique_ptr<TrackFilter> filter,
                   std::shared_ptr<const CovarianceCalibration> calibration);

  /// The features the next cycle's factors come from: plots used since the start and the level.
  [[nodiscard]] long plots_used() const noexcept { return used_; }
  [[nodiscard]] double nis_level() const noexcept { return level_; }  ///< (see plots_used)
  /// The factors of the held prediction (or the last cycle's after it).
  [[nodiscard]] double innovation_scale() const noexcept { return innovation_scale_; }
  [[nodiscard]] double state_scale() const noexcept { return state_scale_; }  ///< (see above)
  /// The filter calibrated.
  [[nodiscard]] const TrackFilter& inner() const noexcept { return *filter_; }
  /// Its calibration.
  [[nodiscard]] const CovarianceCalibration& calibration() const noexcept { return *calibration_; }

  [[nodiscard]] int state_dimension() const override { return filter_->state_dimension(); }
  [[nodiscard]] int mode_count() const override { return filter_->mode_count(); }
  [[nodiscard]] std::string mode_name(int j) const override { return filter_->mode_name(j); }
  void initialize(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) override;
  StepStatus step(const Eigen::Vector2d& z) override;
  StepStatus predict_only() override;
  void state(Eigen::Ref<Eigen::VectorXd> mean, Eigen::Ref<Eigen::VectorXd> variance) const override;
  void covariance(Eigen::Ref<Eigen::MatrixXd> covariance) const override;
  [[nodiscard]] ModeVector mode_probabilities() const override {
    return filter_->mode_probabilities();
  }
  bool innovation(Eigen::Vector2d& nu, Eigen::Matrix2d& S) const override;
  [[nodiscard]] double log_predictive_likelihood() const override {
    return filter_->log_predictive_likelihood();
  }
  [[nodiscard]] bool has_split_cycle() const override { return filter_->has_split_cycle(); }
  [[nodiscard]] bool predicts_before_the_plot() const override {
    return filter_->predicts_before_the_plot();
  }
  StepStatus predict() override;
  [[nodiscard]] double candidate_log_likelihood(const Eigen::Vector2d& z) const override {
    return filter_->candidate_log_likelihood(z);
  }
  [[nodiscard]] double candidate_distance(const Eigen::Vector2d& z) const override;
  bool predicted_plot(Eigen::Vector2d& z_hat, Eigen::Matrix2d& S) const override;
  StepStatus update(const Eigen::Vector2d& z) override;
  StepStatus miss() override;
  [[nodiscard]] bool takes_any_interval() const override { return filter_->takes_any_interval(); }
  bool set_interval(double interval) override { return filter_->set_interval(interval); }

 private:
  void hold_scales() noexcept;
  void after_update() noexcept;

  std::unique_ptr<TrackFilter> filter_;
  std::shared_ptr<const CovarianceCalibration> calibration_;
  long used_ = 0;
  double level_ = 2.0;
  double innovation_scale_ = 1.0, state_scale_ = 1.0;
};

}  // namespace imm
