// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The weighted IMM of seed 004 §3.2 (SPEC §4.6), and the normal IMM it is compared with.
///
/// Modes: CV (4 states, Q = q₁ Γ Γᵀ per axis) and Singer (6 states, exact discretization), mixed in
/// the 6-state space [x, vx, ax, y, vy, ay]; polar plots (range, azimuth atan2(x, y)).
/// Each cycle, before the update:
///   μ̄ = Πᵀ μ (the seed's eq. 6–7, read as μ̄_CV = π₁₁ μ_CV + π₂₁ μ_Singer);
///   θ̄ = circular mean of the modes' predicted azimuths weighted by μ̄ (eq. 9–11);
///   if μ̄_CV > threshold: the plot azimuth becomes θ̄ + α (θ_plot − θ̄) on the circle (eq. 8).
/// The fused plot is then used as FusionVariant says: kNone is the normal IMM; kSeed the seed's
/// reading, the fused azimuth an ordinary plot with R unchanged (linearized for one mode the
/// innovation becomes α ν_θ: the state moves by α K ν while P shrinks as if by K ν); kCorrelated
/// the fused plot with its correlation to the prediction modelled (A = diag(1, α): h_f = A h +
/// (I − A) [·, θ̄], Jacobian A H, covariance A R Aᵀ), whose gain K A⁻¹ makes the update exactly the
/// normal IMM's — fusing the prediction into the plot adds no information.
/// Measurement update: EKF with a wrapped azimuth innovation (default; exact Jacobian, no
/// conversion bias, and the seed's fusion acts on the azimuth it measures) or converted
/// measurements (the plot as a Cartesian position with linearized covariance; kept as an option
/// for comparison — at 140 km the conversion is strongly non-Gaussian across the beam).

#include <Eigen/Core>
#include <memory>
#include <string>

#include "imm/estimation/imm_estimator.hpp"
#include "imm/models/measurement/polar_measurement.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/imm_track_filter.hpp"
#include "imm/tracking/track_options.hpp"

namespace imm {

namespace wimm {
struct Cycle;  ///< what a WimmFilter's cycle chose, shared with its modes (wimm.cpp)
}  // namespace wimm

/// Which measurement a wIMM cycle updated with: a polar plot with the chosen azimuth (the plot's
/// own, or the seed's fused one), the correlated fusion, or the converted Cartesian plot.
enum class AzimuthUse { kPlot, kCorrelated, kConverted };

/// Whether and how the WIMM fuses the plot azimuth with the estimate's (seed 004; see the file
/// comment).
enum class FusionVariant { kNone, kSeed, kCorrelated };
/// The polar measurement update: EKF on (r, θ) or converted Cartesian.
enum class MeasurementUpdate { kExtended, kConverted };

[[nodiscard]] IMM_RUNTIME_EXPORT std::string_view to_string(
    FusionVariant variant);  ///< none | seed | correlated
[[nodiscard]] IMM_RUNTIME_EXPORT std::string_view to_string(
    MeasurementUpdate update);  ///< extended | converted
/// "none" | "seed" | "correlated"; InvalidParameter naming `field` otherwise.
[[nodiscard]] IMM_RUNTIME_EXPORT FusionVariant fusion_variant_from(std::string_view name,
                                                                   const std::string& field);
/// "extended" | "converted"; InvalidParameter naming `field` otherwise.
[[nodiscard]] IMM_RUNTIME_EXPORT MeasurementUpdate
measurement_update_from(std::string_view name, const std::string& field);

/// The weighted IMM of seed 004: a CV and a Singer mode on polar plots, with azimuth fusion when
/// the CV mode dominates.
struct IMM_RUNTIME_EXPORT WimmSpec {
  double sample_period = 0.0;     ///< T, s (unset: from the regime or the model file)
  double cv_process_noise = 2.0;  ///< q₁, (m/s²)²
  double singer_tau = 20.0;       ///< τ, s
  double singer_sigma = 5.0;      ///< σ_a, m/s²
  double range_sigma = 50.0;      ///< σ_R, m
  double azimuth_sigma = 0.5 * 3.14159265358979323846 / 180.0;  ///< σ_θ, rad
  /// Mode switching (CV, Singer), rows sum to 1.
  Eigen::Matrix2d transition = (Eigen::Matrix2d() << 0.95, 0.05, 0.05, 0.95).finished();
  Eigen::Vector2d initial_probabilities = Eigen::Vector2d(0.5, 0.5);  ///< CV, Singer
  double threshold = 0.7;  ///< fuse when μ̄_CV exceeds it
  double alpha = 0.5;      ///< weight of the plot azimuth
  /// The azimuth fusion variant.
  FusionVariant fusion = FusionVariant::kSeed;
  /// The polar update.
  MeasurementUpdate update = MeasurementUpdate::kExtended;
  double acceleration_variance = 25.0;  ///< initial variance of ax, ay (m/s²)²

  /// Throws InvalidParameter naming the field.
  void validate() const;
  /// R = diag(σ_R², σ_θ²).
  [[nodiscard]] Eigen::Matrix2d measurement_covariance() const;
  /// Polar plots, two-point initialization.
  [[nodiscard]] TrackOptions track_options(std::int64_t max_gap = kDefaultMaxGap) const;
};

/// The WIMM as a TrackFilter: state [x, vx, ax, y, vy, ay], polar plots. What it does not
/// override is the IMM's own answer (ImmTrackFilter).
class IMM_RUNTIME_EXPORT WimmFilter final : public ImmTrackFilter<6> {
 public:
  /// Throws InvalidParameter naming the field of an invalid spec.
  explicit WimmFilter(const WimmSpec& spec);

  /// "cv" or "singer".
  [[nodiscard]] std::string mode_name(int j) const override { return j == 0 ? "cv" : "singer"; }
  /// ImmTrackFilter::initialize; the next cycle has not fused yet.
  void initialize(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) override;
  /// One cycle, the azimuth fused where the CV mode dominates (see the file comment).
  StepStatus step(const Eigen::Vector2d& z) override;
  /// The innovation of the plot, combined over the modes (ImmEstimator::innovation): [range,
  /// azimuth], or the converted Cartesian plot under MeasurementUpdate::kConverted. A cycle that
  /// fused updated with the fused azimuth; the plot's innovation and S are still reported, the
  /// modes' rewritten exactly (the seed's fusion: the plot's azimuth in place of the fused one, S
  /// unchanged; the correlated fusion: A⁻¹ ν and A⁻¹ S A⁻ᵀ; converted: the plot's conversion and
  /// its covariance in place of the fused ones), so that the NIS tests the plots the sensor gave.
  bool innovation(Eigen::Vector2d& nu, Eigen::Matrix2d& S) const override;
  /// log p(z | Z^(k−1)) of the plot (not of a fused azimuth), with the modes' terms rewritten as in
  /// innovation(); under the converted update the Cartesian density times the Jacobian r of the
  /// polar-to-Cartesian map, so that every variant gives a density of the same (range, azimuth)
  /// plot and filters of either update compare.
  [[nodiscard]] double log_predictive_likelihood() const override;

  /// The split cycle, without fusion and with the extended update only (the nIMM: the plot is
  /// then the measurement, whatever the prediction); a fusing wIMM chooses its measurement from
  /// the prediction and the plot together and does not split.
  [[nodiscard]] bool has_split_cycle() const override {
    return spec_.fusion == FusionVariant::kNone && spec_.update == MeasurementUpdate::kExtended;
  }
  /// As has_split_cycle() (both modes are Kalman modes).
  [[nodiscard]] bool predicts_before_the_plot() const override { return has_split_cycle(); }
  /// ImmEstimator::predict where has_split_cycle(); else std::logic_error.
  StepStatus predict() override;
  /// ImmEstimator::candidate_log_likelihood (NaN without a split cycle).
  [[nodiscard]] double candidate_log_likelihood(const Eigen::Vector2d& z) const override;
  /// ImmEstimator::candidate_distance (NaN without a split cycle).
  [[nodiscard]] double candidate_distance(const Eigen::Vector2d& z) const override;
  /// ImmEstimator::predicted_plot (false without a split cycle).
  bool predicted_plot(Eigen::Vector2d& z_hat, Eigen::Matrix2d& S) const override;
  /// ImmEstimator::update where has_split_cycle(); else std::logic_error.
  StepStatus update(const Eigen::Vector2d& z) override;
  /// ImmEstimator::miss where has_split_cycle(); else std::logic_error.
  StepStatus miss() override;

  /// Whether the last cycle fused the azimuth.
  [[nodiscard]] bool fused() const { return fused_; }
  /// The spec the filter runs.
  [[nodiscard]] const WimmSpec& spec() const { return spec_; }

 private:
  WimmFilter(const WimmSpec& spec, std::shared_ptr<wimm::Cycle> cycle);

  WimmSpec spec_;
  std::shared_ptr<wimm::Cycle> cycle_;
  bool fused_ = false;
  Vector<2> plot_ = Vector<2>::Zero();    // the last cycle's plot
  Vector<2> chosen_ = Vector<2>::Zero();  // and the measurement it updated with
  AzimuthUse use_ = AzimuthUse::kPlot;    // how
  // Rewrites a mode's innovation of the chosen measurement into the plot's.
  void to_plot(Vector<2>& nu, SquareMatrix<2>& S) const;
};

}  // namespace imm
