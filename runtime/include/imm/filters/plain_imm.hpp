// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// A plain IMM described by parameters: 2-D motion models with fixed process noise per mode — CV,
/// CA, Singer and the coordinated turn (CT, an EKF mode: imm/estimation/turn_mode.hpp) — a
/// Cartesian or polar measurement, a transition matrix, initial mode probabilities and a track
/// initialization. This is the classical IMM family: the filter `imm-track` runs from a TOML file
/// or a "plain_imm" model file, and the reference IMM of the benchmarks and evaluations.
///
/// State layout (mixing space): [x, vx, y, vy] when every mode is CV; [x, vx, ax, y, vy, ay] with
/// a CA or Singer mode; a CT mode adds the turn rate ω last: [x, vx, y, vy, ω] (CV and CT) or
/// [x, vx, ax, y, vy, ay, ω]. Lower-dimensional modes are embedded zero-padded
/// (state_embedding.hpp).

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "imm/estimation/imm_estimator.hpp"
#include "imm/models/learned/fuzzy_rule_table.hpp"
#include "imm/models/motion/motion_model.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/track_options.hpp"

namespace imm {

/// The motion model of a mode.
enum class MotionKind { kConstantVelocity, kConstantAcceleration, kSinger, kCoordinatedTurn };

[[nodiscard]] IMM_RUNTIME_EXPORT std::string_view to_string(
    MotionKind kind);  ///< "cv", "ca", "singer", "ct"
[[nodiscard]] IMM_RUNTIME_EXPORT std::string_view to_string(
    NoiseForm form);  ///< "piecewise", "continuous"
/// Inverse of to_string; throw InvalidParameter naming `field` for unknown names.
[[nodiscard]] IMM_RUNTIME_EXPORT MotionKind motion_kind_from(std::string_view name,
                                                             const std::string& field);
/// "piecewise" | "continuous"; InvalidParameter naming `field` otherwise.
[[nodiscard]] IMM_RUNTIME_EXPORT NoiseForm noise_form_from(std::string_view name,
                                                           const std::string& field);

/// One mode of a plain IMM.
struct IMM_RUNTIME_EXPORT ModeSpec {
  /// The mode's name (reports, mode_name()).
  std::string name;
  /// CV, CA or Singer.
  MotionKind motion = MotionKind::kConstantVelocity;
  /// CV/CA/CT: q of the noise form (variance per period for piecewise-constant noise, PSD for
  /// continuous); for CT that of each axis's linear acceleration. Unused by Singer.
  double process_noise = 0.0;
  /// How q enters Q (CV, CA).
  NoiseForm noise_form = NoiseForm::kPiecewiseConstant;
  double singer_tau = 20.0;   ///< Singer: maneuver time constant τ, s
  double singer_sigma = 0.0;  ///< Singer: acceleration standard deviation σ_a
  /// CT: the turn rate's noise in the form of `noise_form` (rad²/s⁴ per period, or rad²/s³).
  double turn_noise = 0.0;
  /// A learned schedule of the mode's Q (imm/estimation/scheduled_noise_mode.hpp): a rule table
  /// from the mode's normalized innovation d and its change Δd to a dimensionless multiplier of Q.
  /// None: Q is fixed (the classical mode). Not for Singer modes.
  std::optional<FuzzyRuleTable> noise_schedule{};
};

/// The plots a plain IMM takes.
struct IMM_RUNTIME_EXPORT MeasurementSpec {
  /// Cartesian or polar.
  MeasurementKind kind = MeasurementKind::kCartesian;
  /// R: Cartesian [x, y] or polar [range, azimuth (rad)].
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();
};

/// A plain IMM of linear motion modes with a common measurement (frozen by imm-train freeze).
struct IMM_RUNTIME_EXPORT PlainImmSpec {
  /// T, s (unset: from the regime or the model file).
  double sample_period = 0.0;
  /// The modes, 1 to 16.
  std::vector<ModeSpec> modes;
  Eigen::MatrixXd transition;  ///< transition(i, j) = P(mode j at k | mode i at k−1)
  /// μ₀, sums to 1.
  Eigen::VectorXd initial_probabilities;
  /// The plots' kind and R.
  MeasurementSpec measurement;
  /// How a track starts.
  InitializationSpec initialization;

  /// 4 when every mode is CV, 6 with a CA or Singer mode; one more with a CT mode (its ω).
  [[nodiscard]] int mixing_dimension() const;
  /// Whether a mode's Q is scheduled by a learned table (a learned model, not a classical one).
  [[nodiscard]] bool has_noise_schedule() const;
  /// Whether a mode is a coordinated turn (the state then ends with ω).
  [[nodiscard]] bool has_turn_rate() const;
  /// Throws InvalidParameter naming the first offending field.
  void validate() const;
  /// The measurement and initialization of the spec, as a Tracker takes them.
  [[nodiscard]] TrackOptions track_options(std::int64_t max_gap = kDefaultMaxGap) const;
};

/// The modes of a spec in its mixing space NX (4 to 7; must equal spec.mixing_dimension()), in
/// the spec's order: what build_plain_imm assembles, for an IMM that adds modes of its own to them.
template <int NX>
[[nodiscard]] std::vector<std::unique_ptr<ImmMode<NX, 2>>> build_plain_imm_modes(
    const PlainImmSpec& spec);

/// The 4-state modes.
extern template IMM_RUNTIME_EXPORT std::vector<std::unique_ptr<ImmMode<4, 2>>>
build_plain_imm_modes<4>(const PlainImmSpec&);
/// The 6-state modes.
extern template IMM_RUNTIME_EXPORT std::vector<std::unique_ptr<ImmMode<6, 2>>>
build_plain_imm_modes<6>(const PlainImmSpec&);
/// The 5-state modes.
extern template IMM_RUNTIME_EXPORT std::vector<std::unique_ptr<ImmMode<5, 2>>>
build_plain_imm_modes<5>(const PlainImmSpec&);
/// The 7-state modes.
extern template IMM_RUNTIME_EXPORT std::vector<std::unique_ptr<ImmMode<7, 2>>>
build_plain_imm_modes<7>(const PlainImmSpec&);

/// Builds the IMM of a validated spec in its mixing space NX (4 to 7; must equal
/// spec.mixing_dimension()).
template <int NX>
[[nodiscard]] ImmEstimator<NX, 2> build_plain_imm(const PlainImmSpec& spec);

/// The 4-state instantiation (every mode CV).
extern template IMM_RUNTIME_EXPORT ImmEstimator<4, 2> build_plain_imm<4>(const PlainImmSpec&);
/// The 6-state instantiation.
extern template IMM_RUNTIME_EXPORT ImmEstimator<6, 2> build_plain_imm<6>(const PlainImmSpec&);
/// The 5-state instantiation (CV and CT modes).
extern template IMM_RUNTIME_EXPORT ImmEstimator<5, 2> build_plain_imm<5>(const PlainImmSpec&);
/// The 7-state instantiation (CT beside CA or Singer).
extern template IMM_RUNTIME_EXPORT ImmEstimator<7, 2> build_plain_imm<7>(const PlainImmSpec&);

/// The IMM of a spec, whichever its mixing dimension.
using PlainImm =
    std::variant<ImmEstimator<4, 2>, ImmEstimator<6, 2>, ImmEstimator<5, 2>, ImmEstimator<7, 2>>;
/// Builds the IMM of a validated spec in its own mixing dimension.
[[nodiscard]] IMM_RUNTIME_EXPORT PlainImm build_plain_imm(const PlainImmSpec& spec);

}  // namespace imm
