// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The probabilistic TSK fuzzy model of a range sensor (seed 002 §2, eq. 1–4, 9–10): two inputs
/// (ξ lateral, η longitudinal), two outputs, per output c rules
///   Rʳ: if ξ is A₁ʳ and η is A₂ʳ then zʳ = a₀ʳ + a_ξʳ ξ + a_ηʳ η,
///   ẑ = Σ wʳ zʳ / Σ wʳ + n,  n ~ N(0, σ²),  wʳ = T(A₁ʳ(ξ), A₂ʳ(η)),
/// with Gaussian premise sets A(x) = exp(−(x − m)² / (2 s²)) and the t-norm T = min (the seed's)
/// or product.
///
/// Jacobian (the seed's formulas after eq. 10):
///   ∂h/∂x_s = Σ_r [∂wʳ/∂x_s (zʳ − h) + wʳ a_sʳ] / Σ_r wʳ,
/// with ∂wʳ/∂x_s = wʳ · (−(x_s − m_sʳ)/s_sʳ²) for the product, and for the min the same for the
/// input whose membership is the minimum and 0 for the other (at a tie the first input is taken:
/// a subgradient).
///
/// Numerics: firing strengths are formed in log space and scaled by the largest, so that far from
/// every center they do not underflow to 0/0.
///
/// Outside the trained input box a fitted TSK model extrapolates — the consequent hyperplanes
/// keep going while the premise weights freeze on the nearest rule — and the result looks
/// plausible but is not what the sensor does. So the TSK rules are only ever evaluated inside the
/// box: the input is clamped to it and the evaluation flags that it was (`clamped`). What the
/// model returns for the outside point is then a policy:
///   - kLinear (default): the first-order continuation from the clamped point,
///     h(x) = h(x_c) + ∇h(x_c) (x − x_c), Jacobian ∇h(x_c) — continuous, and an EKF through it
///     keeps the information the boundary slope carries;
///   - kHold: h(x) = h(x_c), the Jacobian column of a clamped input 0 (the exact derivative of the
///     held value). An EKF then cannot correct that coordinate at all: a track whose estimate
///     leaves the box (a target beside the host, η < the box) drifts and never comes back —
///     `imm-eval fimm` diverged that way before kLinear became the default.

#include <Eigen/Core>
#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "imm/runtime_export.hpp"

namespace imm {

/// The t-norm combining a rule's two premise memberships.
enum class TNorm { kMin, kProduct };
/// What the model answers outside its trained input box (see the file comment).
enum class OutsideBox { kLinear, kHold };

[[nodiscard]] IMM_RUNTIME_EXPORT std::string_view to_string(TNorm t_norm);  ///< "min" | "product"
/// "min" | "product"; InvalidParameter naming `field` otherwise.
[[nodiscard]] IMM_RUNTIME_EXPORT TNorm t_norm_from(std::string_view name, const std::string& field);

/// One TSK rule: Gaussian premises on (ξ, η), a linear consequent.
struct IMM_RUNTIME_EXPORT TskRule {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();      ///< premise centers m (ξ, η)
  Eigen::Vector2d width = Eigen::Vector2d::Ones();       ///< premise widths s > 0
  Eigen::Vector3d consequent = Eigen::Vector3d::Zero();  ///< a₀, a_ξ, a_η
};

/// The rules of one output and its noise σ.
struct IMM_RUNTIME_EXPORT TskOutput {
  std::vector<TskRule> rules;  ///< 1 … kMaxRules
  double sigma = 0.0;          ///< σ of eq. (7), ≥ 0
};

/// The model at one input: values, Jacobian and whether the input was clamped.
struct IMM_RUNTIME_EXPORT TskEvaluation {
  Eigen::Vector2d value = Eigen::Vector2d::Zero();     ///< (h₁, h₂)
  Eigen::Matrix2d jacobian = Eigen::Matrix2d::Zero();  ///< ∂h_i/∂(ξ, η)
  bool clamped = false;                                ///< the input lay outside the trained box
};

/// The most rules an output may have.
inline constexpr int kTskMaxRules = 32;

/// One output's rules fired at an input: what h, its input gradient (here) and the trainer's
/// parameter gradient are all built from. Entries beyond `rules` are not set (an evaluation fills
/// only what it uses: zeroing the unused slots cost a quarter of an evaluation).
// NOLINTNEXTLINE(cppcoreguidelines-pro-type-member-init): deliberately, see above.
struct IMM_RUNTIME_EXPORT TskFiring {
  std::size_t rules = 0;                            ///< rules used (≤ kTskMaxRules)
  std::array<double, kTskMaxRules> share;           ///< wʳ / Σ w
  std::array<double, kTskMaxRules> rule_output;     ///< zʳ = a₀ʳ + a_ξʳ ξ + a_ηʳ η
  std::array<Eigen::Array2d, kTskMaxRules> scaled;  ///< (x − mʳ) / sʳ per input
  std::array<Eigen::Array2d, kTskMaxRules> active;  ///< 1 for the inputs wʳ depends on, else 0
  double value = 0.0;                               ///< h = Σ shareʳ zʳ
};

/// The two-output TSK sensor model of seed 002 (see the file comment).
class IMM_RUNTIME_EXPORT TskSensorModel {
 public:
  /// The most rules an output may have.
  static constexpr int kMaxRules = kTskMaxRules;

  TskSensorModel() = default;
  /// Throws InvalidParameter naming the field ("outputs[1].rules[0].width", "input_lower", …).
  /// Besides finiteness it requires centers within 10 box widths of the input box and widths
  /// within 10⁻⁶ … 10⁶ box widths, and finite values at the box's corners: then h and ∇h are
  /// finite everywhere in the box (a hostile file cannot make the filter divide 0 by 0).
  TskSensorModel(std::array<TskOutput, 2> outputs, TNorm t_norm, const Eigen::Vector2d& input_lower,
                 const Eigen::Vector2d& input_upper, OutsideBox outside = OutsideBox::kLinear);

  /// h(ξ, η) and its Jacobian; outside the trained box by the OutsideBox policy. Allocation-free.
  [[nodiscard]] TskEvaluation evaluate(const Eigen::Vector2d& input) const;

  /// The firing of a rule set at an (unclamped) input. Allocation-free.
  [[nodiscard]] static TskFiring fire(const std::vector<TskRule>& rules, TNorm t_norm,
                                      const Eigen::Vector2d& input);

  /// One output of a rule set at an (unclamped) input, with ∂/∂input when `gradient` is given —
  /// also used by the trainer on its own candidate rules.
  [[nodiscard]] static double output(const std::vector<TskRule>& rules, TNorm t_norm,
                                     const Eigen::Vector2d& input,
                                     Eigen::Vector2d* gradient = nullptr);

  /// The two outputs' rules and σ.
  [[nodiscard]] const std::array<TskOutput, 2>& outputs() const { return outputs_; }
  /// The t-norm.
  [[nodiscard]] TNorm t_norm() const { return t_norm_; }
  /// What the model answers outside its input box.
  [[nodiscard]] OutsideBox outside_policy() const { return outside_; }
  /// Sets the outside-box policy.
  void set_outside_policy(OutsideBox policy) { outside_ = policy; }
  /// The input box's lower corner (ξ, η).
  [[nodiscard]] const Eigen::Vector2d& input_lower() const { return lower_; }
  /// The input box's upper corner (ξ, η).
  [[nodiscard]] const Eigen::Vector2d& input_upper() const { return upper_; }
  /// diag(σ₁², σ₂²): the model's own noise, added to the sensor's R by the FIMM.
  [[nodiscard]] Eigen::Matrix2d noise_covariance() const;

 private:
  std::array<TskOutput, 2> outputs_{};
  TNorm t_norm_ = TNorm::kMin;
  OutsideBox outside_ = OutsideBox::kLinear;
  Eigen::Vector2d lower_ = Eigen::Vector2d::Constant(-1e300);
  Eigen::Vector2d upper_ = Eigen::Vector2d::Constant(1e300);
};

}  // namespace imm
