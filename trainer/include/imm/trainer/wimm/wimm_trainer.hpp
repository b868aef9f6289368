// SPDX-License-Identifier: Apache-2.0
#pragma once
/// `imm-train wimm --config configs/wimm.toml`: tunes the weighted IMM's fusion threshold and
/// weight α with NLopt on the regime's training split (a polar sensor; for the paper the random
/// geometries, speeds and coordinated turns of configs/regimes/paper/wimm_training.toml, never
/// seed 004's evaluation scenarios) and writes a "wimm" model file.
///
/// Objective (lower is better), shared with the nIMM-tuned baseline so that both are judged alike:
///   J = az / az_nIMM + penalty · max(0, pos / pos_nIMM − 1),
/// az and pos the settled (first_settled_scan on) azimuth and position RMSE averaged over the
/// training scenarios, relative to the seed's normal IMM on the same plots: azimuth accuracy may
/// not be bought with position accuracy.
///
/// A recorded regime without truth for training: the objective is the excess NLL per plot of the
/// plots themselves (score_plots: the density of each plot before it is fused, so a fusion cannot
/// flatter itself), and a fusion learned on a tuned nIMM stays on only when it predicts the
/// validation plots better than that nIMM with an innovation RMS no worse.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include "imm/filters/wimm.hpp"
#include "imm/trainer/wimm/tracking_score.hpp"

namespace imm::trainer::wimm {

struct WimmTrainingConfig {
  std::uint64_t seed = 1;
  datasets::Regime regime;
  /// The seed's nIMM parameters and the fusion variant; T, σ_r and σ_θ are the regime's.
  WimmSpec filter;
  double min_threshold = 0.0, max_threshold = 1.0;
  double min_alpha = 0.05, max_alpha = 1.0;
  int max_evaluations = 150;
  double position_penalty = 10.0;
  /// `tuning.base`: "seed" learns the fusion on the config's nIMM (the seed's q₁ and transition:
  /// the paper preset's literal form); "tuned" first tunes q₁ and P(CV→CV) on the training split
  /// (the nIMM-tuned baseline's search) and learns the fusion on top of that, so that the model
  /// with its fusion off is the tuned nIMM. With "tuned" a fusion that does not beat its nIMM on
  /// the validation split is switched off (the model is then the tuned nIMM, and says so).
  bool on_tuned_normal_imm = false;

  std::string text, name;

  void validate() const;  ///< InvalidParameter naming the key
};

[[nodiscard]] WimmTrainingConfig load_wimm_config(
    const std::filesystem::path& path,
    const std::optional<std::filesystem::path>& regime = std::nullopt);

/// Tracks to tune on: a split of the regime.
using TrainingScenarios = datasets::TrackSet;

struct Tuned {
  WimmSpec spec;
  /// J with truth; from plots alone (a training split without truth) the excess NLL per plot.
  double objective = 0.0;
  double azimuth_ratio = 0.0, position_ratio = 0.0;  ///< settled, against the nIMM (with truth)
  /// From plots alone: the tuned filter's plot score and that of the same filter with its
  /// fusion off.
  PlotScore plots, reference_plots;
  int evaluations = 0;
};

/// J of a spec against the reference (normal IMM) score on the same scenarios.
[[nodiscard]] double objective(const TrackingScore& score, const TrackingScore& reference,
                               double position_penalty);

/// Threshold and α of the weighted IMM.
[[nodiscard]] Tuned tune_wimm(const WimmTrainingConfig& config, const TrainingScenarios& data);
/// q₁ and the CV → CV transition probability of the normal IMM (nIMM-tuned).
[[nodiscard]] Tuned tune_normal_imm(const WimmTrainingConfig& config,
                                    const TrainingScenarios& data);

struct WimmTrainingResult {
  Tuned tuned;
  /// With `tuning.base = "tuned"`: the nIMM the fusion is learned on, and whether the fusion paid
  /// on the validation split (J below 1 against that nIMM); false: the model is that nIMM.
  std::optional<Tuned> base;
  bool learned_part_on = true;
  /// J of the model against its nIMM on the validation split; from plots alone the difference of
  /// their excess NLL per plot.
  double validation_objective = 0.0;
  /// Whether the training split had truth (J and the settled ratios); false: plots alone (the
  /// excess NLL per plot and the innovation RMS, `tuned.plots` against `tuned.reference_plots`).
  bool with_truth = true;
  double wall_seconds = 0.0;
  std::string digest;
};

/// Tunes and writes the model and `<model>.metrics.json`.
WimmTrainingResult train_wimm(const WimmTrainingConfig& config, const std::filesystem::path& out);

/// A polar regime's tuned classical filter (`imm-train baseline` with a wIMM config): the normal
/// IMM with q₁ and P(CV→CV) tuned on the training split (nIMM-tuned, tune_normal_imm), written as
/// a wimm model file with its fusion off (`training.classical_baseline` = 1), and its
/// `<model>.metrics.json`. The same filter a wIMM learned on top of it is with its fusion off.
struct NormalImmBaselineResult {
  Tuned base;  ///< the tuned q₁ and P(CV→CV)
  double wall_seconds = 0.0;
};
NormalImmBaselineResult write_tuned_normal_imm_baseline(const WimmTrainingConfig& config,
                                                        const std::filesystem::path& out);

}  // namespace imm::trainer::wimm
