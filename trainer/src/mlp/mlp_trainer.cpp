// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/mlp/mlp_trainer.hpp"

#include <chrono>
#include <cmath>
#include <optional>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/datasets/axis_trajectory.hpp"
#include "imm/datasets/random.hpp"
#include "imm/datasets/sha256.hpp"
#include "imm/datasets/track.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/baseline_tuning.hpp"
#include "imm/trainer/mlp/smoothed_labels.hpp"
#include "imm/trainer/model_files/write_model.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/regime_checks.hpp"
#include "imm/trainer/training_config.hpp"
#include "imm/trainer/training_set.hpp"

namespace imm::trainer::mlp {
namespace {

// The config's own keys (config_on has read its regime and seed).
void fill(const support::ConfigTable& root, MlpTrainingConfig& c) {
  const double a = acceleration_scale(c.regime);
  c.cv_kf.sample_period = c.regime.sample_period;
  c.cv_kf.measurement_variance = c.regime.sensor.noise.sigma(0) * c.regime.sensor.noise.sigma(0);
  c.cv_kf.process_noise = 0.01 * a * a;
  c.output_scale = 1.2 * a;
  double gate = 0.3;
  if (const auto kf = root.table("cv_kf")) {
    if (!kf->is_auto("process_noise")) c.cv_kf.process_noise = kf->real("process_noise");
  }
  if (const auto n = root.table("network")) {
    if (n->has("hidden")) {
      const Eigen::VectorXd h = n->reals("hidden");
      c.hidden.clear();
      for (Eigen::Index i = 0; i < h.size(); ++i) {
        // Checked before the conversion: a double outside int's range does not convert.
        if (!(h(i) >= 1.0 && h(i) <= 4096.0) || h(i) != std::floor(h(i))) {
          n->fail("hidden", "entry " + std::to_string(i) + " must be a whole number in [1, 4096]");
        }
        c.hidden.push_back(static_cast<int>(h(i)));
      }
    }
    if (n->has("output")) {
      const std::string output = n->text("output");
      if (output == "scaled_sigmoid") {
        c.output = Activation::kSigmoid;
      } else if (output == "linear") {
        c.output = Activation::kLinear;
      } else {
        n->fail("output",
                "unknown output unit '" + output + "' (expected scaled_sigmoid or linear)");
      }
    }
    if (!n->is_auto("output_scale")) c.output_scale = n->real("output_scale");
    c.init_range = n->real_or("init_range", c.init_range);
    if (n->has("input_noise")) {
      const std::string noise = n->text("input_noise");
      if (noise == "none") {
        c.input_noise = MlpTrainingConfig::InputNoise::kNone;
      } else if (noise == "validation") {
        c.input_noise = MlpTrainingConfig::InputNoise::kValidation;
      } else if (noise == "consistent") {
        c.input_noise = MlpTrainingConfig::InputNoise::kConsistent;
      } else {
        n->fail("input_noise",
                "unknown input noise '" + noise + "' (expected none, validation or consistent)");
      }
    }
    if (n->has("sign")) {
      try {
        c.sign = input_sign_from(n->text("sign"), n->path("sign"));
      } catch (const InvalidParameter& error) {
        n->fail("sign", error.message());
      }
    }
  }
  if (const auto t = root.table("training")) {
    if (t->has("mode")) {
      const std::string mode = t->text("mode");
      if (mode == "per_sample") {
        c.training.mode = UpdateMode::kPerSample;
      } else if (mode == "batch") {
        c.training.mode = UpdateMode::kBatch;
      } else {
        t->fail("mode", "unknown mode '" + mode + "' (expected per_sample or batch)");
      }
    }
    if (t->has("optimizer")) {
      const std::string optimizer = t->text("optimizer");
      if (optimizer == "sgd") {
        c.training.optimizer = Optimizer::kGradientDescent;
      } else if (optimizer == "adam") {
        c.training.optimizer = Optimizer::kAdam;
      } else {
        t->fail("optimizer", "unknown optimizer '" + optimizer + "' (expected sgd or adam)");
      }
    }
    if (t->has("phases")) {
      c.training.phases.clear();
      for (const auto& p : t->tables("phases")) {
        c.training.phases.push_back(
            {p.count("epochs"), p.real("hidden_rate"), p.real("output_rate")});
      }
    }
    c.training.loss_every = t->count_or("loss_every", c.training.loss_every);
  }
  if (const auto g = root.table("gate")) gate = g->real_or("max_validation_rmse", gate);
  if (!(gate > 0.0) || !std::isfinite(gate)) {
    root.fail("gate.max_validation_rmse",
              "must be positive (a multiple of the largest acceleration)");
  }
  c.max_validation_rmse = gate * a;
  c.training.seed = datasets::derive_seed(c.seed, 3);
  c.validate();
}

double mean_output(const MlpInputEstimatorModel& model, const Samples& features, bool corrected) {
  double sum = 0.0;
  for (Eigen::Index i = 0; i < features.inputs.rows(); ++i) {
    const Eigen::Vector2d x =
        MlpInputEstimatorFilter::standardize(model, features.inputs.row(i).transpose());
    const double raw = model.network.forward(x);
    sum += corrected ? std::max(0.0, raw - model.output_bias) : raw;
  }
  return features.inputs.rows() > 0 ? sum / static_cast<double>(features.inputs.rows()) : 0.0;
}

}  // namespace

void MlpTrainingConfig::validate() const {
  require_per_axis_sensor(regime, "the input estimator");
  validate_within("cv_kf.", cv_kf);
  require(!hidden.empty() && hidden.size() <= 4, "network.hidden", "1 to 4 hidden layers");
  for (int h : hidden) require(h >= 1 && h <= 256, "network.hidden", "layer sizes in [1, 256]");
  limits::require_in(output_scale, {1e-9, limits::kAcceleration.max, ""}, "network.output_scale");
  require(init_range > 0.0 && init_range <= 10.0, "network.init_range", "must be in (0, 10]");
  require(!training.phases.empty(), "training.phases", "at least one phase");
  for (std::size_t i = 0; i < training.phases.size(); ++i) {
    const auto& phase = training.phases[i];
    const std::string key = "training.phases[" + std::to_string(i) + "].";
    require(phase.epochs >= 0 && phase.epochs <= 1000000, key + "epochs", "must be in [0, 10⁶]");
    require(phase.hidden_rate > 0.0 && phase.hidden_rate <= 100.0, key + "hidden_rate",
            "must be in (0, 100]");
    require(phase.output_rate > 0.0 && phase.output_rate <= 100.0, key + "output_rate",
            "must be in (0, 100]");
  }
  require(training.loss_every >= 1, "training.loss_every", "must be positive");
  require(max_validation_rmse > 0.0 && std::isfinite(max_validation_rmse),
          "gate.max_validation_rmse", "must be positive");
}

MlpTrainingConfig load_mlp_config(const std::filesystem::path& path,
                                  const std::optional<std::filesystem::path>& regime) {
  return load_training_config<MlpTrainingConfig>(path, fill, regime);
}

FeatureSet make_features(const MlpTrainingConfig& config, const datasets::TrackSet& tracks) {
  const double T = config.cv_kf.sample_period;
  const double R = config.cv_kf.measurement_variance;
  std::vector<Eigen::Vector2d> inputs;
  std::vector<double> targets;
  for (const datasets::AxisTrajectory& truth : datasets::axis_trajectories(tracks)) {
    InnovationFeatureExtractor extractor(config.cv_kf);
    extractor.initialize(datasets::two_point_start(truth, T, R));
    for (Eigen::Index k = 2; k < truth.measurement.size(); ++k) {
      Eigen::Vector2d features;
      if (extractor.step(truth.measurement(k), features) != StepStatus::kOk) continue;
      inputs.push_back(features);
      // The magnitude of the acceleration acting from scan k on (the sign is the filter's).
      targets.push_back(std::abs(truth.acceleration_input(k)));
    }
  }
  FeatureSet set;
  set.samples.inputs.resize(static_cast<Eigen::Index>(inputs.size()), 2);
  set.samples.targets.resize(static_cast<Eigen::Index>(targets.size()));
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    set.samples.inputs.row(static_cast<Eigen::Index>(i)) = inputs[i].transpose();
    set.samples.targets(static_cast<Eigen::Index>(i)) = targets[i];
  }
  set.digest = tracks.digest();
  return set;
}

namespace {

/// The mean of term(filter, axis, k) over the model's filter run on each axis (two-point start),
/// over the steps k ≥ 2 before the last `skip_last` scans that succeed and whose term is not
/// empty; `none` when there is no such step.
template <class Term>
double mean_over_steps(const MlpInputEstimatorModel& model,
                       const std::vector<datasets::AxisTrajectory>& axes, Eigen::Index skip_last,
                       double none, Term&& term) {
  const double T = model.settings.sample_period;
  const double R = model.settings.measurement_variance;
  double sum = 0.0;
  std::size_t count = 0;
  for (const datasets::AxisTrajectory& axis : axes) {
    MlpInputEstimatorFilter filter(model, model.settings);
    filter.initialize(datasets::two_point_start(axis, T, R));
    for (Eigen::Index k = 2; k + skip_last < axis.measurement.size(); ++k) {
      if (filter.step(axis.measurement(k)) != StepStatus::kOk) continue;
      if (const std::optional<double> value = term(filter, axis, k)) {
        sum += *value;
        ++count;
      }
    }
  }
  return count > 0 ? sum / static_cast<double>(count) : none;
}

/// E[(û(k) − a(k))²] of the filter over the tracks: its signed input estimate against the
/// acceleration that acts over the transition it is used for (the sign's and the lag's errors
/// included), per axis.
double signed_input_mse(const MlpInputEstimatorModel& model, const datasets::TrackSet& tracks) {
  return mean_over_steps(
      model, datasets::axis_trajectories(tracks), 1, 0.0,
      [](const MlpInputEstimatorFilter& filter, const datasets::AxisTrajectory& truth,
         Eigen::Index k) -> std::optional<double> {
        const double error = filter.acceleration() - truth.acceleration_input(k);
        return error * error;
      });
}

/// The primary KF's mean normalized innovation squared ν²/S over the tracks' axis runs with the
/// model as it is (its input_variance included): 1 for a consistent 1-D filter. Plots only.
double mean_nis(const MlpInputEstimatorModel& model,
                const std::vector<datasets::AxisTrajectory>& axes) {
  return mean_over_steps(model, axes, 0, 1.0,
                         [](const MlpInputEstimatorFilter& filter, const datasets::AxisTrajectory&,
                            Eigen::Index) -> std::optional<double> {
                           double nu = 0.0, variance = 0.0;
                           if (!filter.innovation(nu, variance) || !(variance > 0.0)) {
                             return std::nullopt;
                           }
                           return nu * nu / variance;
                         });
}

/// The input variance σ_û² ≥ 0 at which the primary KF's mean NIS over `tracks` is 1 (its
/// dimension): the NIS falls as σ_û² grows, so a bracket by quadrupling and then bisection.
/// σ_û² = E[(û − a)²] takes the input's errors as white; they are not (the network reads ten
/// scans, so an error lasts as long as a manoeuvre's onset), and the filter stays optimistic.
double consistent_input_variance(MlpInputEstimatorModel model, const datasets::TrackSet& tracks) {
  const std::vector<datasets::AxisTrajectory> axes = datasets::axis_trajectories(tracks);
  const auto nis_at = [&](double variance) {
    model.input_variance = variance;
    return mean_nis(model, axes);
  };
  if (nis_at(0.0) <= 1.0) return 0.0;
  double low = 0.0;
  double high = std::max(model.settings.process_noise, 1e-12);
  for (int i = 0; i < 80 && nis_at(high) > 1.0; ++i) {
    low = high;
    high *= 4.0;
  }
  for (int i = 0; i < 50; ++i) {
    const double middle = 0.5 * (low + high);
    (nis_at(middle) > 1.0 ? low : high) = middle;
  }
  return high;
}

/// The regime without maneuvers: its start (the first case's for a scripted one), its sensor. A
/// recorded regime has no start: a target at rest at the origin (the features of a CV KF on a
/// target without manoeuvre depend on the plot noise alone).
datasets::Regime quiet_regime(const datasets::Regime& regime) {
  if (regime.recorded) {
    datasets::Regime quiet;
    quiet.name = regime.name + "_quiet";
    quiet.units = regime.units;
    quiet.sample_period = regime.sample_period;
    quiet.scans = regime.scans;
    quiet.sensor = regime.sensor;
    quiet.sensor.estimate_sigma = false;
    quiet.start.fixed = true;
    datasets::MenuEntry cruise;
    cruise.probability = 1.0;
    cruise.duration = {regime.sample_period * regime.scans, regime.sample_period * regime.scans};
    quiet.menu = {cruise};
    quiet.splits = {1, 1, 1, regime.splits.seed};
    quiet.validate();
    return quiet;
  }
  datasets::Regime quiet = regime;
  if (regime.scripted() && regime.cases.front().start) quiet.start = *regime.cases.front().start;
  quiet.cases.clear();
  datasets::MenuEntry cruise;
  cruise.probability = 1.0;
  cruise.duration = {regime.sample_period * regime.scans, regime.sample_period * regime.scans};
  quiet.menu = {cruise};
  return quiet;
}

}  // namespace

MlpTrainingResult train_mlp(const MlpTrainingConfig& config, const std::filesystem::path& out) {
  config.validate();
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  MlpTrainingResult result;
  const datasets::Regime& regime = config.regime;
  const std::uint64_t seed = regime.splits.seed;
  datasets::TrackSet training_tracks =
      datasets::draw_split(regime, datasets::Split::kTraining, seed);
  datasets::TrackSet validation_tracks =
      datasets::draw_split(regime, datasets::Split::kValidation, seed);
  const bool plots_only = !regime.trains_from_truth();
  if (plots_only) {  // labels from the smoother of the tuned IMM (smoothed_labels.hpp)
    require_gap_free(regime, training_tracks);
    require_gap_free(regime, validation_tracks);
    AxisImmSettings settings;
    settings.sample_period = regime.sample_period;
    settings.measurement_sigma = regime.sensor.noise.sigma(0);
    const TrainingSet plots = make_training_set(regime, datasets::Split::kTraining);
    const Tuned<AxisCvImmSpec> smoother =
        tune_imm_baseline(settings, {plots}, acceleration_scale(regime));
    result.smoother = smoother.spec;
    training_tracks = smoothed_truth(training_tracks, smoother.spec);
    validation_tracks = smoothed_truth(validation_tracks, smoother.spec);
  }
  const FeatureSet training = make_features(config, training_tracks);
  const FeatureSet validation = make_features(config, validation_tracks);
  const datasets::Regime quiet_tracks = quiet_regime(regime);
  const FeatureSet quiet =  // sets the bias
      make_features(config,
                    datasets::draw_split(quiet_tracks, datasets::Split::kTraining, seed, 1));
  const FeatureSet quiet_check =  // reports it
      make_features(config,
                    datasets::draw_split(quiet_tracks, datasets::Split::kValidation, seed, 1));

  // Standardization from the training features.
  MlpInputEstimatorModel& model = result.model;
  model.settings = config.cv_kf;
  model.sign = config.sign;
  const Eigen::MatrixXd& x = training.samples.inputs;
  model.input_mean = x.colwise().mean().transpose();
  model.input_scale =
      ((x.rowwise() - model.input_mean.transpose()).cwiseAbs2().colwise().mean().cwiseSqrt())
          .transpose();
  for (int i = 0; i < 2; ++i) {
    if (!(model.input_scale(i) > 0.0)) model.input_scale(i) = 1.0;
  }
  auto standardized = [&](const Samples& raw) {
    Samples s = raw;
    for (Eigen::Index i = 0; i < s.inputs.rows(); ++i) {
      s.inputs.row(i) =
          MlpInputEstimatorFilter::standardize(model, raw.inputs.row(i).transpose()).transpose();
    }
    return s;
  };
  const Samples train_set = standardized(training.samples);
  const Samples validation_set = standardized(validation.samples);

  std::vector<int> sizes = {2};
  sizes.insert(sizes.end(), config.hidden.begin(), config.hidden.end());
  sizes.push_back(1);
  Network network(sizes, config.output, config.output_scale, config.init_range,
                  datasets::derive_seed(config.seed, 2));
  const auto training_start = Clock::now();
  result.loss = train(network, train_set, validation_set, config.training);
  result.training_seconds = std::chrono::duration<double>(Clock::now() - training_start).count();
  model.network = network.to_mlp();
  result.training_rmse = std::sqrt(network.mse(train_set));
  result.validation_rmse = std::sqrt(network.mse(validation_set));

  model.output_bias = mean_output(model, quiet.samples, false);
  result.bias_before = mean_output(model, quiet_check.samples, false);
  result.bias_after = mean_output(model, quiet_check.samples, true);
  if (config.input_noise == MlpTrainingConfig::InputNoise::kValidation) {
    // The whole model as the filter runs it (network, bias, sign) on the validation split.
    model.input_variance = signed_input_mse(model, validation_tracks);
  } else if (config.input_noise == MlpTrainingConfig::InputNoise::kConsistent) {
    // The calibration that makes the primary KF's NIS average 1 on the tracks it may see.
    datasets::TrackSet seen = training_tracks;
    seen.tracks.insert(seen.tracks.end(), validation_tracks.tracks.begin(),
                       validation_tracks.tracks.end());
    model.input_variance = consistent_input_variance(model, seen);
  }
  datasets::Sha256 digest;
  digest.update(training.digest);
  digest.update(validation.digest);
  result.digest = digest.hex_digest();
  result.gate_passed =
      std::isfinite(result.validation_rmse) && result.validation_rmse <= config.max_validation_rmse;
  result.wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (!result.gate_passed) return result;

  io::Provenance provenance = provenance_of(io::kMlpInputEstimatorKind, config, result.digest);
  provenance.training_metrics["rmse"] = result.training_rmse;
  if (plots_only) provenance.training_metrics["labels_rts_smoother"] = 1.0;
  provenance.validation_metrics["rmse"] = result.validation_rmse;
  provenance.training_metrics["bias_before"] = result.bias_before;
  provenance.training_metrics["bias_after"] = result.bias_after;
  Eigen::MatrixXd curve(static_cast<Eigen::Index>(result.loss.size()), 3);
  for (std::size_t i = 0; i < result.loss.size(); ++i) {
    curve.row(static_cast<Eigen::Index>(i)) << result.loss[i].epoch, result.loss[i].training,
        result.loss[i].validation;
  }
  write_model_file(out, provenance, [&](io::ModelFileWriter& writer) {
    io::write_mlp_input_estimator(writer, model, curve);
  });

  nlohmann::json metrics = metrics_of(io::kMlpInputEstimatorKind, out, config.name);
  metrics["seed"] = config.seed;
  metrics["regime"] = config.regime.name;
  metrics["training_samples"] = train_set.inputs.rows();
  metrics["validation_samples"] = validation_set.inputs.rows();
  metrics["training_rmse"] = result.training_rmse;
  metrics["validation_rmse"] = result.validation_rmse;
  metrics["output_bias"] = model.output_bias;
  metrics["bias_before"] = result.bias_before;
  metrics["bias_after"] = result.bias_after;
  metrics["training_seconds"] = result.training_seconds;
  metrics["wall_seconds"] = result.wall_seconds;
  metrics["loss_columns"] = {"epoch", "training_mse", "validation_mse"};
  for (const auto& p : result.loss) metrics["loss"].push_back({p.epoch, p.training, p.validation});
  write_json_atomically(metrics_path(out), metrics);
  return result;
}

}  // namespace imm::trainer::mlp
