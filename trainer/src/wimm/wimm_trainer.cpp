// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/wimm/wimm_trainer.hpp"

#include <chrono>
#include <cmath>
#include <functional>
#include <numbers>
#include <optional>
#include <utility>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/datasets/random.hpp"
#include "imm/io/wimm_file.hpp"
#include "imm/support/bounded_search.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/model_files/write_model.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/regime_checks.hpp"
#include "imm/trainer/training_config.hpp"

namespace imm::trainer::wimm {
namespace {

// The config's own keys (config_on has read its regime and seed).
void fill(const support::ConfigTable& root, WimmTrainingConfig& c) {
  WimmSpec& s = c.filter;
  s.sample_period = c.regime.sample_period;
  s.range_sigma = c.regime.sensor.noise.sigma(0);
  s.azimuth_sigma = c.regime.sensor.noise.sigma(1);
  if (const auto f = root.table("filter")) {
    s.cv_process_noise = f->real_or("cv_process_noise", s.cv_process_noise);
    s.singer_tau = f->real_or("singer_tau", s.singer_tau);
    s.singer_sigma = f->real_or("singer_sigma", s.singer_sigma);
    if (f->has("transition")) s.transition = f->matrix("transition", 2, 2);
    if (f->has("initial_probabilities"))
      s.initial_probabilities = f->reals("initial_probabilities", 2);
    s.threshold = f->real_or("threshold", s.threshold);
    s.alpha = f->real_or("alpha", s.alpha);
    if (f->has("fusion")) s.fusion = fusion_variant_from(f->text("fusion"), f->path("fusion"));
    if (f->has("update")) s.update = measurement_update_from(f->text("update"), f->path("update"));
    s.acceleration_variance = f->real_or("acceleration_variance", s.acceleration_variance);
  }
  if (const auto u = root.table("tuning")) {
    if (u->has("threshold_range")) {
      const Eigen::VectorXd r = u->reals("threshold_range", 2);
      c.min_threshold = r(0), c.max_threshold = r(1);
    }
    if (u->has("alpha_range")) {
      const Eigen::VectorXd r = u->reals("alpha_range", 2);
      c.min_alpha = r(0), c.max_alpha = r(1);
    }
    c.max_evaluations = u->count_or("max_evaluations", c.max_evaluations);
    c.position_penalty = u->real_or("position_penalty", c.position_penalty);
    if (u->has("base")) {
      const std::string base = u->text("base");
      require(base == "seed" || base == "tuned", u->path("base"),
              "must be \"seed\" (the config's nIMM) or \"tuned\" (q1 and P(CV->CV) tuned on "
              "the training split first), not \"" +
                  base + "\"");
      c.on_tuned_normal_imm = base == "tuned";
    }
  }
  c.validate();
}

Tuned tune(const WimmTrainingConfig& config, const TrainingScenarios& data,
           const std::function<WimmSpec(const std::vector<double>&)>& make,
           const std::vector<double>& lower, const std::vector<double>& upper) {
  WimmSpec reference_spec = config.filter;
  reference_spec.fusion = FusionVariant::kNone;
  const Eigen::Vector2d& sensor = config.regime.sensor.position;
  // With truth: J against the fusion-off filter. From plots alone: the excess NLL of the plots.
  std::optional<TrackingScore> reference;
  if (data.has_truth) reference = score_tracking(reference_spec, data, sensor);
  auto f = [&](const std::vector<double>& x) {
    if (!reference) return score_plots(make(x), data).excess_nll;
    return objective(score_tracking(make(x), data, sensor), *reference, config.position_penalty);
  };
  const int grid = 6;
  const support::SearchResult search = support::grid_then_subplex(
      f, lower, upper,
      {.grid_points = grid,
       .polish_evaluations = std::max(0, config.max_evaluations - grid * grid),
       .xtol_rel = 1e-3});
  Tuned tuned;
  tuned.spec = make(search.x);
  tuned.objective = search.value;
  tuned.evaluations = search.evaluations + 1;
  if (!reference) {
    tuned.plots = score_plots(tuned.spec, data);
    tuned.reference_plots = score_plots(reference_spec, data);
    return tuned;
  }
  const TrackingScore score = score_tracking(tuned.spec, data, sensor);
  tuned.azimuth_ratio = score.azimuth_settled / reference->azimuth_settled;
  tuned.position_ratio = score.position_settled / reference->position_settled;
  return tuned;
}

}  // namespace

void WimmTrainingConfig::validate() const {
  require_sensor(regime, datasets::SensorKind::kPolar, "the weighted IMM");
  for (int c = 0; c < regime.case_count(); ++c) {
    require(regime.noise_of(c) == regime.sensor.noise, "regime",
            "the weighted IMM is built for one plot noise; regime '" + regime.name +
                "' varies it from case to case");
  }
  validate_within("filter.", filter);
  require(regime.scans > first_settled_scan(regime.scans) + 1, "regime",
          "regime '" + regime.name + "' is too short to settle");
  require(min_threshold < max_threshold && min_threshold >= 0.0 && max_threshold <= 1.0,
          "tuning.threshold_range", "must be [min, max] within [0, 1], min < max");
  require(min_alpha > 0.0 && max_alpha <= 1.0 && min_alpha < max_alpha, "tuning.alpha_range",
          "must be [min, max] within (0, 1]");
  require(max_evaluations >= 1 && max_evaluations <= 1000000, "tuning.max_evaluations",
          "must be in [1, 10⁶]");
  limits::require_in(position_penalty, limits::kFactor, "tuning.position_penalty");
}

WimmTrainingConfig load_wimm_config(const std::filesystem::path& path,
                                    const std::optional<std::filesystem::path>& regime) {
  return load_training_config<WimmTrainingConfig>(path, fill, regime);
}

double objective(const TrackingScore& score, const TrackingScore& reference,
                 double position_penalty) {
  const double position_ratio = score.position_settled / reference.position_settled;
  const double value = score.azimuth_settled / reference.azimuth_settled +
                       position_penalty * std::max(0.0, position_ratio - 1.0);
  return std::isfinite(value) ? value : std::numeric_limits<double>::max();
}

Tuned tune_wimm(const WimmTrainingConfig& config, const TrainingScenarios& data) {
  return tune(config, data,
              [&](const std::vector<double>& x) {
                WimmSpec spec = config.filter;
                if (spec.fusion == FusionVariant::kNone) spec.fusion = FusionVariant::kSeed;
                spec.threshold = x[0];
                spec.alpha = x[1];
                return spec;
              },
              {config.min_threshold, config.min_alpha}, {config.max_threshold, config.max_alpha});
}

Tuned tune_normal_imm(const WimmTrainingConfig& config, const TrainingScenarios& data) {
  // log10 q₁ ∈ [−3, 2], P(CV → CV) ∈ [0.5, 0.999]; the Singer row keeps the seed's values.
  return tune(config, data,
              [&](const std::vector<double>& x) {
                WimmSpec spec = config.filter;
                spec.fusion = FusionVariant::kNone;
                spec.cv_process_noise = std::pow(10.0, x[0]);
                spec.transition(0, 0) = x[1];
                spec.transition(0, 1) = 1.0 - x[1];
                return spec;
              },
              {-3.0, 0.5}, {2.0, 0.999});
}

WimmTrainingResult train_wimm(const WimmTrainingConfig& config, const std::filesystem::path& out) {
  const auto start = std::chrono::steady_clock::now();
  const TrainingScenarios data =
      datasets::draw_split(config.regime, datasets::Split::kTraining, config.regime.splits.seed);
  WimmTrainingResult result;
  WimmTrainingConfig on_top = config;
  if (config.on_tuned_normal_imm) {
    // The fusion on top of the tuned nIMM: its q₁ and transition row become the model's.
    result.base = tune_normal_imm(config, data);
    on_top.filter.cv_process_noise = result.base->spec.cv_process_noise;
    on_top.filter.transition = result.base->spec.transition;
  }
  result.tuned = tune_wimm(on_top, data);
  if (config.on_tuned_normal_imm) {
    // Against the model's own nIMM on tracks the tuning has not seen. With truth J below 1, the
    // fusion pays; from plots alone a lower excess NLL of the plots and an innovation RMS no worse
    // (the rule the GA keeps its tables by without truth).
    const TrainingScenarios validation = datasets::draw_split(
        config.regime, datasets::Split::kValidation, config.regime.splits.seed);
    WimmSpec normal = on_top.filter;
    normal.fusion = FusionVariant::kNone;
    const Eigen::Vector2d& sensor = config.regime.sensor.position;
    if (validation.has_truth) {
      result.validation_objective =
          objective(score_tracking(result.tuned.spec, validation, sensor),
                    score_tracking(normal, validation, sensor), config.position_penalty);
      result.learned_part_on = result.tuned.objective < 1.0 && result.validation_objective < 1.0;
    } else {
      const PlotScore learned = score_plots(result.tuned.spec, validation);
      const PlotScore plain = score_plots(normal, validation);
      result.validation_objective = learned.excess_nll - plain.excess_nll;
      result.learned_part_on = result.tuned.objective < result.tuned.reference_plots.excess_nll &&
                               result.validation_objective < 0.0 &&
                               learned.innovation_rms <= plain.innovation_rms;
    }
    if (!result.learned_part_on) {
      result.tuned.spec = normal;
      result.tuned.objective = data.has_truth ? 1.0 : result.tuned.reference_plots.excess_nll;
      result.tuned.azimuth_ratio = 1.0;
      result.tuned.position_ratio = 1.0;
      result.tuned.plots = result.tuned.reference_plots;
    }
  }
  result.with_truth = data.has_truth;
  result.digest = data.digest();
  result.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  io::Provenance provenance = provenance_of(io::kWimmKind, config, result.digest);
  provenance.training_metrics["objective"] = result.tuned.objective;
  if (data.has_truth) {
    provenance.training_metrics["azimuth_ratio"] = result.tuned.azimuth_ratio;
    provenance.training_metrics["position_ratio"] = result.tuned.position_ratio;
  } else {  // the objective is the plots' excess NLL
    provenance.training_metrics["trained_without_truth"] = 1.0;
    provenance.training_metrics["innovation_rms"] = result.tuned.plots.innovation_rms;
    provenance.training_metrics["nimm_excess_nll"] = result.tuned.reference_plots.excess_nll;
  }
  if (result.base) {
    provenance.training_metrics["on_tuned_nimm"] = 1.0;
    provenance.training_metrics["learned_part_on"] = result.learned_part_on ? 1.0 : 0.0;
    provenance.validation_metrics["objective"] = result.validation_objective;
  }
  write_model_file(out, provenance,
                   [&](io::ModelFileWriter& writer) { io::write_wimm(writer, result.tuned.spec); });

  nlohmann::json metrics = metrics_of(io::kWimmKind, out, config.name);
  metrics["seed"] = config.seed;
  metrics["threshold"] = result.tuned.spec.threshold;
  metrics["alpha"] = result.tuned.spec.alpha;
  metrics["objective"] = result.tuned.objective;
  if (data.has_truth) {
    metrics["azimuth_ratio_settled"] = result.tuned.azimuth_ratio;
    metrics["position_ratio_settled"] = result.tuned.position_ratio;
  } else {
    metrics["criterion"] = "excess NLL per plot (no truth: learned from the plots alone)";
    metrics["excess_nll"] = result.tuned.plots.excess_nll;
    metrics["innovation_rms_sigma"] = result.tuned.plots.innovation_rms;
    metrics["nimm_excess_nll"] = result.tuned.reference_plots.excess_nll;
    metrics["nimm_innovation_rms_sigma"] = result.tuned.reference_plots.innovation_rms;
  }
  metrics["evaluations"] = result.tuned.evaluations;
  metrics["base"] = config.on_tuned_normal_imm ? "tuned" : "seed";
  if (result.base) {
    metrics["base_nimm"] = {{"cv_process_noise", result.base->spec.cv_process_noise},
                            {"stay", result.base->spec.transition(0, 0)},
                            {"evaluations", result.base->evaluations}};
    metrics["validation_objective"] = result.validation_objective;
    metrics["learned_part_on"] = result.learned_part_on;
  }
  metrics["regime"] = config.regime.name;
  metrics["training_tracks"] = data.tracks.size();
  metrics["wall_seconds"] = result.wall_seconds;
  write_json_atomically(metrics_path(out), metrics);
  return result;
}

NormalImmBaselineResult write_tuned_normal_imm_baseline(const WimmTrainingConfig& config,
                                                        const std::filesystem::path& out) {
  const auto start = std::chrono::steady_clock::now();
  const TrainingScenarios data =
      datasets::draw_split(config.regime, datasets::Split::kTraining, config.regime.splits.seed);
  NormalImmBaselineResult result{tune_normal_imm(config, data), 0.0};
  const Tuned& base = result.base;
  io::Provenance provenance = provenance_of(io::kWimmKind, config, data.digest());
  provenance.training_metrics["on_tuned_nimm"] = 1.0;
  provenance.training_metrics["learned_part_on"] = 0.0;
  provenance.training_metrics["classical_baseline"] = 1.0;
  if (!data.has_truth) provenance.training_metrics["trained_without_truth"] = 1.0;
  write_model_file(out, provenance,
                   [&](io::ModelFileWriter& writer) { io::write_wimm(writer, base.spec); });

  nlohmann::json metrics = metrics_of(io::kWimmKind, out, config.name);
  metrics["classical_baseline"] =
      "the normal IMM with q1 and P(CV->CV) tuned on the training split (fusion off)";
  metrics["regime"] = config.regime.name;
  metrics["baseline"] = {{"cv_process_noise", base.spec.cv_process_noise},
                         {"stay", base.spec.transition(0, 0)},
                         {"evaluations", base.evaluations}};
  if (!data.has_truth) {
    metrics["criterion"] = "excess NLL per plot (no truth: learned from the plots alone)";
  }
  result.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  metrics["wall_seconds"] = result.wall_seconds;
  write_json_atomically(metrics_path(out), metrics);
  return result;
}

}  // namespace imm::trainer::wimm
