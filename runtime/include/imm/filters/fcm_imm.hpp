// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The FCM acceleration-compensating IMM of seed 003 (SPEC §4.5), per axis, in a dimensionally
/// consistent and stable form.
///
/// Derivation. One axis, x = [p, v], F = [[1, T], [0, 1]], G = [T²/2, T]ᵀ, H = [1 0].
///  1. The predicted impact point p̂ + v̂T (eq. 11–12) is H F x̂₀, the position of the CV
///     prediction from the mixed estimate x̂₀, and its error e = z − H F x̂₀ (eq. 13–14) is the CV
///     innovation, of nominal variance S = H P⁻ Hᵀ + R with P⁻ = F P₀ Fᵀ + q G Gᵀ (q: the mode's
///     noise level).
///  2. FCM (fuzzy_c_means.hpp) gives the error's memberships u = [u_dec, u_noise, u_acc] and
///     splits it into d̂ = u_dec e, η̂ = u_noise e, â = u_acc e (eq. 15–17) — all three positions,
///     d̂ + η̂ + â = e. The manoeuvre part is m̂ = â + d̂ = (1 − u_noise) e.
///  3. An acceleration a held over the last period moves the state by G a, the position by
///     a T²/2. Reading m̂ as that displacement, a = 2 m̂ / T², and the seed's compensation G(â + d̂)
///     (eq. 21, there with a position where an acceleration belongs) becomes
///     G · 2m̂/T² = ĝ m̂ with ĝ = [1, 2/T]ᵀ. We scale it by a compensation gain λ ∈ [0, 1]:
///     m̂ = c e with c = λ (1 − u_noise).
///  4. The filter updates the compensated prediction F x̂₀ + ĝ m̂ with the remaining error
///     η̂ = z − H(F x̂₀ + ĝ m̂) = e − m̂ (H ĝ = 1), the seed's K η̂. Altogether
///        x̂ = F x̂₀ + K_c e,   K_c = c ĝ + (1 − c) K = K + c (ĝ − K),   K = P⁻ Hᵀ / S:
///     an update of the CV prediction with a modified gain. The seed's eq. (18) puts η̂ (a
///     position) where a variance belongs; the mode keeps its nominal Q = q G Gᵀ instead. Eq. (22)
///     must be P − K S Kᵀ for the Kalman gain; for K_c the error covariance is the Joseph form
///        P = (I − K_c H) P⁻ (I − K_c H)ᵀ + K_c R K_cᵀ,
///     exact for a gain that does not depend on the error — here c does, through u, so P is the
///     first-order (c held fixed) covariance. c = 0 is the plain Kalman update.
///  5. Degeneracy at full strength. c = 1 gives K_c = ĝ: an α–β filter with α = 1, β = 2, whose
///     one-step error transition (I − ĝ H) F = [[0, 0], [−2/T, −1]] has eigenvalues 0 and −1 —
///     marginally stable; measurement noise drives the velocity error as a random walk,
///     E ṽ² growing by 16σ²/T² per step. The seed's FCM memberships depend only on distance
///     ratios inside the window (scale-free), so on pure noise too three clusters form and about
///     half of every error is labelled manoeuvre: c ≈ λ/2 whether or not the target manoeuvres,
///     and with λ = 1 the velocity error is several times the plain filter's
///     (MembershipScale::kSeed; tests/runtime/fcm_imm_test.cpp measures it).
///  6. Scale-aware memberships (MembershipScale::kInnovation, the default): the FCM clusters the
///     normalized errors ε = e / √S, with the noise cluster pinned at ε = 0 and the deceleration
///     and acceleration clusters kept at ε ≤ −κ and ε ≥ κ (the separation κ, in innovation
///     standard deviations). On noise the outer clusters sit at ±κ, errors stay near 0 and c is
///     small; errors of a manoeuvre lie beyond κ, and the acceleration cluster follows them.
///  7. IMM likelihood: N(e; 0, S), the full error under the nominal S. The compensated residual
///     e − m̂ would reward a mode for compensating, whatever the truth.
///  8. Several such filters with different noise levels q_j form the IMM (seed Fig. 3); the
///     lowest-noise one may be left uncompensated (compensate_lowest = false) as a plain anchor
///     for straight flight. With constant_memberships the clustering is replaced by the fixed
///     mean memberships of the training runs — the ablation that isolates what the clustering
///     adds.
///
/// A missed plot has no error: propose_prediction() predicts and leaves the window alone.
/// Nothing is allocated per step.

#include <Eigen/Core>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "imm/estimation/imm_mode.hpp"
#include "imm/estimation/kalman_filter.hpp"
#include "imm/filters/axis_filter.hpp"
#include "imm/filters/fcm_mode_step.hpp"
#include "imm/models/learned/fuzzy_c_means.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/track_options.hpp"

namespace imm {

/// How the innovation errors are scaled before clustering (see the file comment).
enum class MembershipScale {
  kSeed,        ///< the seed's scale-free FCM: free centers, the middle cluster is noise
  kInnovation,  ///< errors in innovation standard deviations, noise pinned at 0, |outer| ≥ κ
};

[[nodiscard]] IMM_RUNTIME_EXPORT std::string_view to_string(
    MembershipScale scale);  ///< seed | innovation
/// Parses "seed" or "innovation"; throws InvalidParameter naming `field` otherwise.
[[nodiscard]] IMM_RUNTIME_EXPORT MembershipScale membership_scale_from(std::string_view name,
                                                                       const std::string& field);

/// The FCM-IMM of one axis (seed 003): CV Kalman filters at ascending process-noise levels,
/// compensated by fuzzy c-means memberships of the recent innovation errors.
struct IMM_RUNTIME_EXPORT FcmImmSpec {
  double sample_period = 0.0;        ///< T, s (unset: from the regime or the model file)
  double measurement_sigma = 100.0;  ///< σ_z per axis
  /// q_j of Q_j = q_j G Gᵀ per mode, (unit/s²)², ascending; 1 to 8 modes.
  std::vector<double> process_noise = {1.0, 100.0, 2500.0};
  Eigen::MatrixXd transition = switching_transition(3, 0.95);  ///< rows sum to 1
  /// μ₀, sums to 1.
  Eigen::VectorXd initial_probabilities = Eigen::VectorXd::Constant(3, 1.0 / 3.0);

  FuzzyCMeansSettings clustering;  ///< fuzzifier m, tolerance, iteration cap
  int window = 16;                 ///< errors per sliding window, [3, 128]
  /// How the errors are scaled before clustering.
  MembershipScale scale = MembershipScale::kInnovation;
  double separation = 3.0;         ///< κ ≥ 0 (kInnovation only)
  double compensation_gain = 0.1;  ///< λ ∈ [0, 1]
  bool compensate_lowest = true;   ///< false: mode 0 is a plain KF

  bool constant_memberships = false;  ///< the ablation: mean_memberships instead of the FCM
  Eigen::MatrixXd mean_memberships;   ///< modes × 3 (dec, noise, acc), rows sum to 1; may be empty

  /// The number of modes (process-noise levels).
  [[nodiscard]] int mode_count() const { return static_cast<int>(process_noise.size()); }
  /// Throws InvalidParameter naming the field.
  void validate() const;
  /// Cartesian plots with σ_z² I, two-point initialization.
  [[nodiscard]] TrackOptions track_options(std::int64_t max_gap = kDefaultMaxGap) const;

  /// p_jj = stay, the rest spread evenly (n = 1: [[1]]).
  [[nodiscard]] static Eigen::MatrixXd switching_transition(int n, double stay);
};

/// What mode `mode` of `spec` steps with (fcm_mode_step.hpp): T, σ_z², its Q, its compensation
/// gain (λ, 0 for an uncompensated lowest mode), ĝ₁ = 2/T and the clustering's scale. The spec must
/// be valid.
[[nodiscard]] IMM_RUNTIME_EXPORT lanes::FcmModeConstants fcm_mode_constants(const FcmImmSpec& spec,
                                                                            int mode);

/// One FCM-compensated CV Kalman filter, one axis (derivation above); its step is
/// fcm_mode_step.hpp's for a double, the one FcmImmTrackBank runs over packs.
class IMM_RUNTIME_EXPORT FcmCompensatedMode final : public ImmMode<2, 1> {
 public:
  /// `mode` indexes spec's process_noise and mean_memberships.
  FcmCompensatedMode(const FcmImmSpec& spec, int mode);

  [[nodiscard]] std::string_view name() const override { return name_; }
  /// The current estimate (already in mixing space).
  void embedded_estimate(Vector<2>& mean, SquareMatrix<2>& covariance) const override {
    mean = estimate_.mean;
    covariance = estimate_.covariance;
  }
  /// Sets the estimate and clears the error window.
  void reset(const GaussianState<2>& state) override;
  /// Predicts from `mixed`, updates with z and applies the FCM compensation; pending until
  /// commit().
  ModeStep propose(const GaussianState<2>& mixed, const Vector<1>& z) override;
  /// Predicts from `mixed` without a measurement; pending until commit().
  ModeStep propose_prediction(const GaussianState<2>& mixed) override;
  /// F times the mixed mean.
  void predicted_mean(const GaussianState<2>& mixed, Vector<2>& mean) const override {
    mean.noalias() = F_ * mixed.mean;
  }
  /// After propose_prediction(): ν and S of a candidate plot at the prediction without a plot
  /// (no compensation); the IMM scores candidates by trial updates, this is for the gate's
  /// predicted plot.
  bool candidate_innovation(const Vector<1>& z, Vector<1>& nu, SquareMatrix<1>& S) const override {
    return score_candidate(pending_, z, H_, R_, nu, S);
  }
  /// After propose_prediction(): ẑ and S of the prediction without a plot.
  bool predicted_plot(Vector<1>& z_hat, SquareMatrix<1>& S) const override {
    return predict_plot(pending_, H_, R_, z_hat, S);
  }
  void commit() override;

  /// Memberships [dec, noise, acc] of the last committed error ([0, 1, 0] before any).
  [[nodiscard]] const ClusterVector& memberships() const { return memberships_; }
  /// The error e(k) = z − H F x̂₀ of the last committed step (eq. 13).
  [[nodiscard]] double error() const { return error_; }
  /// c = λ (1 − u_noise) of the last committed step (0 for an uncompensated mode).
  [[nodiscard]] double compensation() const { return compensation_; }
  /// The current estimate.
  [[nodiscard]] const GaussianState<2>& estimate() const { return estimate_; }

 private:
  std::string name_;
  lanes::FcmModeConstants constants_;
  SquareMatrix<2> F_;
  Matrix<1, 2> H_;
  SquareMatrix<1> R_;
  bool constant_ = false;
  ClusterVector constant_memberships_ = ClusterVector(0.0, 1.0, 0.0);
  SlidingFuzzyCMeans clustering_;

  GaussianState<2> estimate_;
  GaussianState<2> pending_;
  ClusterVector memberships_ = ClusterVector(0.0, 1.0, 0.0);
  ClusterVector pending_memberships_ = ClusterVector(0.0, 1.0, 0.0);
  double compensation_ = 0.0, pending_compensation_ = 0.0;
  double error_ = 0.0, pending_error_ = 0.0;
  bool pending_clustered_ = false;
};

/// The per-axis FCM-IMM.
class IMM_RUNTIME_EXPORT FcmImmAxisFilter final : public ImmAxisFilter {
 public:
  /// Throws InvalidParameter naming the field of an invalid spec.
  explicit FcmImmAxisFilter(const FcmImmSpec& spec);

  /// Mode j of the axis IMM.
  [[nodiscard]] const FcmCompensatedMode& mode(int j) const {
    return *modes_[static_cast<std::size_t>(j)];
  }
  /// The manoeuvre fraction Σ_j μ_j (1 − u_noise,j) of the last step.
  [[nodiscard]] double maneuver_fraction() const;
  /// The compensation Σ_j μ_j c_j of the last step.
  [[nodiscard]] double compensation() const;

 private:
  std::vector<const FcmCompensatedMode*> modes_;  // the IMM's modes, owned by it
};

/// The one-axis FCM-IMM of the spec (throws InvalidParameter naming the field).
[[nodiscard]] IMM_RUNTIME_EXPORT ImmEstimator<2, 1> build_fcm_axis_imm(const FcmImmSpec& spec);

/// The 2-D FCM-IMM (an FcmImmAxisFilter per axis).
[[nodiscard]] IMM_RUNTIME_EXPORT std::unique_ptr<TwoAxisFilter> make_fcm_imm_filter(
    const FcmImmSpec& spec);

}  // namespace imm
