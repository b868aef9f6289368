// SPDX-License-Identifier: Apache-2.0
#pragma once
/// `imm-train fcm --config configs/fcm_imm.toml`: fits the FCM-IMM's free parameters (seed 003;
/// SPEC §6 fcm) — the sub-filters' noise levels q_j, the transition probability, the window
/// length, the fuzzifier m, the separation κ and the compensation gain λ — with NLopt on the
/// regime's training split, checks them on its validation split, measures the mean memberships
/// for the constant-membership ablation and writes an "fcm_imm" model file.
///
/// Objective (lower is better), shared with the baselines tuned for the evaluation so that all
/// are judged alike: J = (pos RMSE + T · vel RMSE) / σ_z over every scan from the third on,
/// both axes, all trajectories. Fit: first the constant-q IMM (λ = 0: q_j and the stay
/// probability), then, for each window length of the config, Subplex over all continuous
/// parameters from that point; the best window wins. λ = 0 is inside the search box, so the fit
/// cannot end worse than the IMM it starts from on the training set.
///
/// The search boxes scale with the regime: log10 q by default spans 10⁻⁷ a² … 9 a², a the regime's
/// largest commanded acceleration (imm/trainer/regime_checks.hpp), so one config serves any
/// regime and unit.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "imm/datasets/track.hpp"
#include "imm/filters/aimm.hpp"
#include "imm/filters/axis_cv_imm.hpp"
#include "imm/filters/fcm_imm.hpp"

namespace imm::trainer::fcm {

struct FcmTuning {
  std::vector<int> windows = {8, 16, 32};
  double min_log_q = -2.0, max_log_q = 4.5;  ///< log10 q, (unit/s²)²
  double min_stay = 0.8, max_stay = 0.995;
  double min_gain = 0.0, max_gain = 1.0;
  double min_fuzzifier = 1.2, max_fuzzifier = 4.0;
  double min_separation = 0.5, max_separation = 6.0;
  int max_evaluations = 150;  ///< Subplex budget per window

  /// The automatic log10 q box of a regime (`log10_q = "auto"`): [log10(1e-7 a²), log10(9 a²)],
  /// a the regime's acceleration scale (regime_checks.hpp).
  void set_automatic_log_q(const datasets::Regime& regime);
};

struct FcmTrainingConfig {
  std::uint64_t seed = 1;
  datasets::Regime regime;
  /// Fixed parts (T and σ_z: the regime's; the number of modes, the membership scale,
  /// compensate_lowest, the FCM tolerance and iteration cap) and the starting values of the fitted
  /// ones.
  FcmImmSpec filter;
  double initial_first_probability = 0.6;  ///< μ₁(0); the rest spread evenly
  FcmTuning tuning;
  double max_validation_ratio = 1.0;  ///< gate: J_val(FCM-IMM) ≤ ratio · J_val(KF-tuned)

  std::string text, name;

  void validate() const;  ///< InvalidParameter naming the key
};

[[nodiscard]] FcmTrainingConfig load_fcm_config(
    const std::filesystem::path& path,
    const std::optional<std::filesystem::path>& regime = std::nullopt);

/// The config a model was trained from, from the text it recorded (`name` for messages) on the
/// regime it recorded (its own `regime` key is not followed). ConfigError naming the key.
[[nodiscard]] FcmTrainingConfig fcm_config_from_text(const std::string& text,
                                                     const std::string& name,
                                                     const datasets::Regime& regime);

/// The training config of a model: the one it recorded (fcm_config_from_text), or, when that text
/// does not load here, one from its own spec with the automatic q range; `note` then says why.
[[nodiscard]] FcmTrainingConfig model_training_config(const std::string& text,
                                                      const std::string& name,
                                                      const datasets::Regime& regime,
                                                      const FcmImmSpec& spec, std::string& note);

/// Tracks to score on: a split of a regime.
using TrackingData = datasets::TrackSet;

struct TrackingScore {
  double position_rmse = 0.0, velocity_rmse = 0.0;  ///< NaN without truth
  /// (pos + T · vel) / σ_z; without truth (a recorded regime's plots alone) the excess NLL per
  /// plot, −1/N Σ log p(z | Z^(k−1)) − log(2π e σ_z²) (both axes' plot entropy). +∞ when a filter
  /// failed.
  double objective = 0.0;
};

using FilterFactory = std::function<std::unique_ptr<TwoAxisFilter>()>;

/// Runs `make()` over every track of `data` (two-point start at scans 0, 1) and scores scans 2 …
/// on, against the truth or — for a set without it — by the plots' predictive likelihood
/// (TrackFilter::log_predictive_likelihood). Tracks run in parallel; the result does not depend
/// on the thread count.
[[nodiscard]] TrackingScore score_filter(const FilterFactory& make, const TrackingData& data,
                                         double measurement_sigma);

template <class Spec>
struct Tuned {
  Spec spec;
  TrackingScore score;
  int evaluations = 0;
};

/// The baselines of the evaluation, tuned on the same trajectories with the same objective.
/// KF: one CV KF per axis, q ∈ 10^[min_log_q, max_log_q].
[[nodiscard]] Tuned<AxisCvImmSpec> tune_kf(const FcmTrainingConfig& config,
                                           const TrackingData& data);
/// IMM-tuned: the constant-q CV IMM with the config's number of modes; q_j and the stay
/// probability; μ(0) as the FCM-IMM's.
[[nodiscard]] Tuned<AxisCvImmSpec> tune_cv_imm(const FcmTrainingConfig& config,
                                               const TrackingData& data);
/// AIMM (one interval, AIMM3): ε, the sub-models' σ_w and the bias filter's σ_b.
[[nodiscard]] Tuned<AimmSpec> tune_aimm(const FcmTrainingConfig& config, const TrackingData& data);

/// The FCM-IMM spec of a fitted constant-q IMM (λ = 0): identical filter.
[[nodiscard]] FcmImmSpec fcm_spec_from(const FcmTrainingConfig& config, const AxisCvImmSpec& imm);

/// Mean memberships per mode (modes × 3) of `spec`'s filter over `data`, both axes, scans 2 …
[[nodiscard]] Eigen::MatrixXd mean_memberships(const FcmImmSpec& spec, const TrackingData& data);

struct WindowFit {
  int window = 0;
  double objective = 0.0;
  int evaluations = 0;
};

struct FcmTrainingResult {
  FcmImmSpec spec;  ///< fitted, with mean_memberships
  TrackingScore training, validation;
  TrackingScore imm_training, imm_validation;  ///< the λ = 0 starting point (IMM-tuned)
  TrackingScore kf_validation;                 ///< the gate's reference
  std::vector<WindowFit> windows;
  int evaluations = 0;
  double wall_seconds = 0.0;
  bool gate_passed = false;
  /// False when no window's fit with λ > 0 beat the tuned constant-q IMM on the training split
  /// (or the fit drove λ to 0): the model is then that IMM (λ = 0), and the log, the model file
  /// (`training.learned_part_on` = 0), the metrics and the fcm-imm report say so.
  bool learned_part_on = true;
  std::string digest;
};

/// Fits and, when the gate passes, writes the model and `<model>.metrics.json` (the metrics are
/// written either way).
FcmTrainingResult train_fcm(const FcmTrainingConfig& config, const std::filesystem::path& out);

}  // namespace imm::trainer::fcm
