// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The classical IMM a tracking engineer would pick for manoeuvring targets, tuned on a regime's
/// training split: constant-velocity, constant-acceleration and coordinated-turn modes (the CT
/// mode an EKF with the turn rate in its state; Bar-Shalom, Li & Kirubarajan, *Estimation with
/// Applications to Tracking and Navigation*, §11.7, the default of MATLAB's `initekfimm`), frozen
/// as a `plain_imm` model file. `imm-train baseline` writes it from a config with a `[classical]`
/// table; every learned model of the regime is then measured against it.
///
/// What is learned, on the training split only: which modes (each candidate mode set of the
/// config is tuned, the best kept), each mode's noise intensities (the CV and CA modes' q, the CT
/// mode's linear-acceleration and turn-rate q) and one mean sojourn per mode set (the stay
/// probability p of every mode, the rest of its row spread evenly). Objective: with truth,
/// ζ_p + ζ_v of seed 000 (NormalizedErrors) over the training tracks, run as the tracker runs them
/// (two-point start); from plots alone, the excess predictive NLL per plot. Search: a grid over
/// the box (log intensities, log(1 − p)), then Subplex from its best point
/// (imm/support/bounded_search.hpp). The boxes scale with the regime — its largest commanded
/// acceleration a, its largest speed v and period T — never with its tracks:
///   q_CV, q_CT ∈ [10⁻⁶, 1] a²;  q_CA ∈ [10⁻⁶, 1] (a/T)²;  q_ω ∈ [10⁻⁸, 1] (ω_a/T)², with
///   ω_a = min(a/v, π/(2T), 2π rad/s) (no filter follows a quarter turn per period);
///   p ∈ [0.5, 1 − 10⁻⁴]; the turn rate starts at 0 with variance ω_a², the CA mode's
///   acceleration at 0 with variance a² (each within the runtime's limits).

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "imm/datasets/regime.hpp"
#include "imm/datasets/track.hpp"
#include "imm/filters/plain_imm.hpp"

namespace imm::trainer::classical {

/// A candidate set of modes, e.g. {CV, CT}.
using ModeSet = std::vector<MotionKind>;

/// "cv,ca,ct" ↔ {CV, CA, CT}; InvalidParameter naming `field` for an unknown or repeated mode, or
/// a Singer mode (not a classical mode here).
[[nodiscard]] ModeSet mode_set_from(std::string_view text, const std::string& field);
[[nodiscard]] std::string to_string(const ModeSet& modes);

struct ClassicalImmConfig {
  datasets::Regime regime;
  std::uint64_t seed = 0;  ///< recorded; the search itself is deterministic
  /// The candidate mode sets; the best on the training split is kept.
  std::vector<ModeSet> mode_sets = {
      {MotionKind::kConstantVelocity, MotionKind::kCoordinatedTurn},
      {MotionKind::kConstantVelocity, MotionKind::kConstantAcceleration,
       MotionKind::kCoordinatedTurn}};
  int grid_points = 3;           ///< per searched dimension
  int polish_evaluations = 120;  ///< Subplex's budget after the grid, per mode set
  /// With a `[schedule]` table: learn noise schedules on the tuned IMM (noise_schedule.hpp) with
  /// this Subplex budget (`imm-train schedule`); `imm-train baseline` ignores it.
  std::optional<int> schedule_evaluations;
  std::string text, name;  ///< the config's text and file (provenance)
};

/// Loads a config with a `[classical]` table (configs/classical_imm.toml); `regime_override` is the
/// command line's --regime. ConfigError naming the key.
[[nodiscard]] ClassicalImmConfig load_classical_config(
    const std::filesystem::path& path,
    const std::optional<std::filesystem::path>& regime_override = std::nullopt);

/// Whether a config file holds a `[classical]` table (what `imm-train baseline` dispatches on).
[[nodiscard]] bool is_classical_config(const std::filesystem::path& path);

/// The spec of a mode set at a point of the search box (x: log10 intensities in mode order — the
/// CT mode contributes two — then log10(1 − p)), for a regime.
[[nodiscard]] PlainImmSpec classical_spec(const datasets::Regime& regime, const ModeSet& modes,
                                          const std::vector<double>& x);

/// The search box of a mode set on a regime (lower, upper), in classical_spec's coordinates.
struct SearchBox {
  std::vector<double> lower, upper;
};
[[nodiscard]] SearchBox search_box(const datasets::Regime& regime, const ModeSet& modes);

/// The objective of a spec over tracks: ζ_p + ζ_v (with truth) or the excess NLL per plot (without
/// truth); +∞ when a step fails. Deterministic at any thread count (per-track terms summed in
/// track order).
struct ClassicalScore {
  double objective = 0.0;
  double zeta_p = 0.0, zeta_v = 0.0;  ///< with truth
  double excess_nll = 0.0;            ///< −1/N Σ log p(z | Z) − ½ log((2πe)² det R)
  long plots = 0;
};
[[nodiscard]] ClassicalScore score_classical(const PlainImmSpec& spec,
                                             const datasets::TrackSet& data);

struct TunedClassicalImm {
  PlainImmSpec spec;
  ModeSet modes;
  ClassicalScore score;
  int evaluations = 0;
  /// Every mode set tried, with its best objective (the report of "which modes").
  std::vector<std::pair<std::string, double>> tried;
  std::string criterion;  ///< "zeta_p_plus_zeta_v" or "excess_nll"
};

/// Tunes every mode set of the config on `training` and keeps the best.
[[nodiscard]] TunedClassicalImm tune_classical_imm(const ClassicalImmConfig& config,
                                                   const datasets::TrackSet& training);

struct LearnedSchedule;

struct ClassicalImmResult {
  TunedClassicalImm tuned;
  /// With config.schedule_evaluations: the schedule's learning (on or off) and, when it switched
  /// off on a small split, the warning that says so (learning_curve.hpp).
  std::shared_ptr<const LearnedSchedule> schedule;
  std::string small_split_warning;
  double wall_seconds = 0.0;
};

/// Draws the regime's training split, tunes, and writes the plain_imm model file `out` (with
/// `classical_baseline` = 1 and `learned_part_on` = 0 in its training metrics) and its metrics
/// file beside it. With config.schedule_evaluations it then learns the noise schedules on top
/// (validated on the validation split) and writes a learned model instead: `classical_baseline`
/// = 0, `noise_schedule` = 1, `learned_part_on` 1 or 0 (off: exactly the tuned IMM).
ClassicalImmResult write_classical_imm(const ClassicalImmConfig& config,
                                       const std::filesystem::path& out);

}  // namespace imm::trainer::classical
