// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Fitting one output of a two-input probabilistic TSK model (seed 002 §2.2):
///
/// Coarse tuning — fuzzy c-regression models (FCRM; the seed's steps 1–5): c hyperplane clusters
/// zʳ = xᵀPʳ, x = (1, ξ, η); memberships from the residual distances d_qʳ = |z_q − x_qᵀPʳ| in the
/// standard fuzzy c-means form μ_qʳ = 1 / Σ_s (d_qʳ / d_qˢ)^{2/(m−1)} (the seed prints the ratio
/// inverted), with the special case of a sample lying exactly on one or more hyperplanes (I_q ≠ ∅:
/// those share the sample, the others get 0); each Pʳ by weighted least squares with weights
/// (μ_qʳ)^m; stop when max |U(l) − U(l−1)| ≤ ε. A single start often stops in a local minimum,
/// so several random starts are run and the lowest objective Σ (μ_qʳ)^m (d_qʳ)² is kept.
///
/// Premises from the clusters: for rule r and input s the membership-weighted mean and standard
/// deviation of the samples (weights μ^m) give the Gaussian's center and width; the
/// consequents start at the hyperplanes.
///
/// Fine tuning — all premise and consequent parameters by Levenberg–Marquardt (Ceres) on the
/// squared error of eq. (5), with analytic derivatives (widths as log s, so they stay positive);
/// the seed's gradient step (6) is the first-order version of the same objective. Then σ by
/// eq. (7) on the training samples.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "imm/models/learned/tsk_sensor_model.hpp"

namespace imm::trainer::tsk {

struct FcrmSettings {
  int clusters = 3;
  double fuzzifier = 2.0;  ///< m > 1
  double tolerance = 1e-5;
  int max_iterations = 300;
  int restarts = 10;

  /// Throws InvalidParameter naming the setting as a TSK config's [fit] table spells it ("rules",
  /// "fuzzifier", …). The config's loader and fcrm() both call it.
  void validate() const;
};

struct FcrmResult {
  Eigen::MatrixXd hyperplanes;  ///< c × 3: (p₀, p_ξ, p_η) per cluster
  Eigen::MatrixXd memberships;  ///< N × c
  double objective = 0.0;
  int iterations = 0;
  bool converged = false;
  int restarts = 0;
};

/// Memberships of one sample with residual distances `distances` (c entries) — the membership
/// update of step 2 with its I_q special case. Sums to 1.
[[nodiscard]] Eigen::VectorXd fcrm_memberships(const Eigen::VectorXd& distances, double fuzzifier);

/// FCRM from the memberships `initial` (N × c, rows sum to 1).
[[nodiscard]] FcrmResult fcrm_from(const Eigen::MatrixXd& inputs, const Eigen::VectorXd& targets,
                                   const Eigen::MatrixXd& initial, const FcrmSettings& settings);

/// FCRM with settings.restarts random starts (seeded); the lowest objective wins.
[[nodiscard]] FcrmResult fcrm(const Eigen::MatrixXd& inputs, const Eigen::VectorXd& targets,
                              const FcrmSettings& settings, std::uint64_t seed);

/// TSK rules from FCRM clusters (premises from the weighted moments, consequents = hyperplanes).
[[nodiscard]] std::vector<TskRule> rules_from_clusters(const Eigen::MatrixXd& inputs,
                                                       const FcrmResult& clusters,
                                                       double fuzzifier);

/// The TSK output of `rules` at every row of `inputs`.
[[nodiscard]] Eigen::VectorXd predict(const std::vector<TskRule>& rules, TNorm t_norm,
                                      const Eigen::MatrixXd& inputs);

[[nodiscard]] double rmse(const std::vector<TskRule>& rules, TNorm t_norm,
                          const Eigen::MatrixXd& inputs, const Eigen::VectorXd& targets);

/// ∂ẑ/∂θ at one input for θ = per rule [m_ξ, log s_ξ, m_η, log s_η, a₀, a_ξ, a_η] (7c entries);
/// returns ẑ. Used by the fine tuning; tested against finite differences.
double output_and_parameter_gradient(const std::vector<TskRule>& rules, TNorm t_norm,
                                     const Eigen::Vector2d& input, double* gradient);

struct FineTuning {
  int max_iterations = 200;
};

struct FineTuningReport {
  int iterations = 0;
  double initial_cost = 0.0, final_cost = 0.0;
  bool converged = false;
};

/// Levenberg–Marquardt on Σ (z − ẑ)² / 2 over all parameters, in place.
FineTuningReport fine_tune(std::vector<TskRule>& rules, TNorm t_norm, const Eigen::MatrixXd& inputs,
                           const Eigen::VectorXd& targets, const FineTuning& settings);

}  // namespace imm::trainer::tsk
