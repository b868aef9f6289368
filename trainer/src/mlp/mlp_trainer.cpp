#include "imm/trainer/mlp/mlp_trainer.hpp"

#include <chrono>
#include <cmath>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/datasets/axis_trajectory.hpp"
#include "imm/datasets/random.hpp"
#include "imm/datasets/sha256.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/training_config.hpp"

namespace imm::trainer::mlp {
namespace {

std::vector<ManeuverPulse> profile_from(const support::ConfigTable& table) {
  std::vector<ManeuverPulse> pulses;
  const Eigen::MatrixXd m = table.matrix("maneuvers", -1, 3);
  for (Eigen::Index i = 0; i < m.rows(); ++i) pulses.push_back({m(i, 0), m(i, 1), m(i, 2)});
  return pulses;
}

MlpTrainingConfig config_from(const support::ConfigTable& root) {
  MlpTrainingConfig c;
  c.seed = root.seed_or("seed", 1);
  if (const auto kf = root.table("cv_kf")) {
    c.cv_kf.sample_period = kf->real_or("sample_period", c.cv_kf.sample_period);
    c.cv_kf.process_noise = kf->real_or("process_noise", c.cv_kf.process_noise);
    if (kf->has("measurement_sigma")) {
      const double sigma = kf->real("measurement_sigma");
      if (!limits::contains(limits::kSigma, sigma)) {
        kf->fail("measurement_sigma", "must be in " + limits::describe(limits::kSigma));
      }
      c.cv_kf.measurement_variance = sigma * sigma;
    }
  }
  if (const auto d = root.table("data")) {
    c.initial_speed = d->real_or("initial_speed", c.initial_speed);
    c.duration = d->real_or("duration", c.duration);
    c.realizations = d->count_or("realizations", c.realizations);
    c.quiet_duration = d->real_or("quiet_duration", c.quiet_duration);
    for (const auto& p : d->tables("training")) c.training_profiles.push_back(profile_from(p));
    for (const auto& p : d->tables("validation")) c.validation_profiles.push_back(profile_from(p));
  }
  if (const auto n = root.table("network")) {
    if (n->has("hidden")) {
      const Eigen::VectorXd h = n->reals("hidden");
      c.hidden.clear();
      for (Eigen::Index i = 0; i < h.size(); ++i) c.hidden.push_back(static_cast<int>(h(i)));
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
    c.output_scale = n->real_or("output_scale", c.output_scale);
    c.init_range = n->real_or("init_range", c.init_range);
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
  if (const auto g = root.table("gate")) {
    c.max_validation_rmse = g->real_or("max_validation_rmse", c.max_validation_rmse);
  }
  c.training.seed = datasets::derive_seed(c.seed, 3);
  c.validate();
  return c;
}

// The input u(k) of a profile on scans 0 … n−1 (a pulse covers start ≤ kT < start + duration).
Eigen::VectorXd input_of(const std::vector<ManeuverPulse>& pulses, int steps, double T) {
  Eigen::VectorXd u = Eigen::VectorXd::Zero(steps);
  for (const auto& p : pulses) {
    for (int k = 0; k < steps; ++k) {
      const double t = k * T;
      if (t >= p.start && t < p.start + p.duration) u(k) += p.acceleration;
    }
  }
  return u;
}

double mean_output(const InputEstimatorModel& model, const Samples& features, bool corrected) {
  double sum = 0.0;
  for (Eigen::Index i = 0; i < features.inputs.rows(); ++i) {
    const Eigen::Vector2d x =
        InputEstimationFilter::standardize(model, features.inputs.row(i).transpose());
    const double raw = model.network.forward(x);
    sum += corrected ? std::max(0.0, raw - model.output_bias) : raw;
  }
  return features.inputs.rows() > 0 ? sum / static_cast<double>(features.inputs.rows()) : 0.0;
}

}  // namespace

void MlpTrainingConfig::validate() const {
  try {
    cv_kf.validate();
  } catch (const InvalidParameter& error) {
    throw(error.field() == "measurement_variance"
              ? InvalidParameter("measurement_sigma",
                                 "must be in " + limits::describe(limits::kSigma))
              : error)
        .within("cv_kf.");
  }
  limits::require_magnitude(initial_speed, limits::kSpeed, "data.initial_speed");
  // Every trajectory is simulated scan by scan: at most kMaxScans of them.
  constexpr double kMaxScans = 1e6;
  const double T = cv_kf.sample_period;
  require(duration >= 20.0 * T && duration <= kMaxScans * T, "data.duration",
          "must cover 20 to 10⁶ scans of cv_kf.sample_period");
  require(quiet_duration >= 20.0 * T && quiet_duration <= kMaxScans * T, "data.quiet_duration",
          "must cover 20 to 10⁶ scans of cv_kf.sample_period");
  require(realizations >= 1 && realizations <= 1000, "data.realizations", "must be in [1, 1000]");
  require(!training_profiles.empty(), "data.training", "at least one [[data.training]] profile");
  require(!validation_profiles.empty(), "data.validation",
          "at least one [[data.validation]] profile");
  for (const auto* set : {&training_profiles, &validation_profiles}) {
    for (std::size_t i = 0; i < set->size(); ++i) {
      const std::string key =
          std::string(set == &training_profiles ? "data.training" : "data.validation") + "[" +
          std::to_string(i) + "].maneuvers";
      for (const auto& p : (*set)[i]) {
        require(limits::contains(limits::kDuration, p.start) && p.duration > 0.0 &&
                    p.duration <= limits::kDuration.max &&
                    limits::contains(limits::kAcceleration, std::abs(p.acceleration)),
                key,
                "rows are [start s ≥ 0, duration s > 0, acceleration], within " +
                    limits::describe(limits::kDuration) + " and |a| ≤ " +
                    limits::describe(limits::kAcceleration));
      }
    }
  }
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

MlpTrainingConfig load_mlp_config(const std::filesystem::path& path) {
  return load_training_config<MlpTrainingConfig>(path, config_from);
}

FeatureSet make_features(const MlpTrainingConfig& config,
                         const std::vector<std::vector<ManeuverPulse>>& profiles,
                         std::uint64_t stream) {
  const double T = config.cv_kf.sample_period;
  const int steps = static_cast<int>(config.duration / T);
  const datasets::AxisNoise noise{T, 0.0, std::sqrt(config.cv_kf.measurement_variance)};
  std::vector<Eigen::Vector2d> inputs;
  std::vector<double> targets;
  datasets::Sha256 hash;
  int trajectory = 0;
  for (const auto& profile : profiles) {
    const Eigen::VectorXd u = input_of(profile, steps, T);
    for (int r = 0; r < config.realizations; ++r, ++trajectory) {
      const auto truth = datasets::simulate_axis(
          0.0, config.initial_speed, u, noise,
          datasets::derive_seed(config.seed,
                                stream * 1000 + static_cast<std::uint64_t>(trajectory)));
      hash.update(truth.measurement.data(),
                  static_cast<std::size_t>(truth.measurement.size()) * sizeof(double));
      InnovationFeatureExtractor extractor(config.cv_kf);
      const double R = config.cv_kf.measurement_variance;
      GaussianState<2> start;
      start.mean << truth.measurement(1), (truth.measurement(1) - truth.measurement(0)) / T;
      start.covariance << R, R / T, R / T, 2.0 * R / (T * T);
      extractor.initialize(start);
      for (int k = 2; k < steps; ++k) {
        Eigen::Vector2d features;
        if (extractor.step(truth.measurement(k), features) != StepStatus::kOk) continue;
        inputs.push_back(features);
        targets.push_back(u(k));  // the acceleration acting from scan k on
      }
    }
  }
  FeatureSet set;
  set.samples.inputs.resize(static_cast<Eigen::Index>(inputs.size()), 2);
  set.samples.targets.resize(static_cast<Eigen::Index>(targets.size()));
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    set.samples.inputs.row(static_cast<Eigen::Index>(i)) = inputs[i].transpose();
    set.samples.targets(static_cast<Eigen::Index>(i)) = targets[i];
  }
  set.digest = hash.hex_digest();
  return set;
}

MlpTrainingResult train_mlp(const MlpTrainingConfig& config, const std::filesystem::path& out) {
  config.validate();
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  MlpTrainingResult result;
  const FeatureSet training = make_features(config, config.training_profiles, 1);
  const FeatureSet validation = make_features(config, config.validation_profiles, 2);
  MlpTrainingConfig quiet_config = config;
  quiet_config.duration = config.quiet_duration;
  const FeatureSet quiet = make_features(quiet_config, {{}}, 3);        // sets the bias
  const FeatureSet quiet_check = make_features(quiet_config, {{}}, 4);  // reports it

  // Standardization from the training features.
  InputEstimatorModel& model = result.model;
  model.settings = config.cv_kf;
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
          InputEstimationFilter::standardize(model, raw.inputs.row(i).transpose()).transpose();
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
  datasets::Sha256 digest;
  digest.update(training.digest);
  digest.update(validation.digest);
  result.digest = digest.hex_digest();
  result.gate_passed =
      std::isfinite(result.validation_rmse) && result.validation_rmse <= config.max_validation_rmse;
  result.wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (!result.gate_passed) return result;

  io::Provenance provenance =
      make_provenance(std::string(io::kMlpInputEstimatorKind), config.text,
                      static_cast<std::int64_t>(config.seed), result.digest);
  provenance.training_metrics["rmse"] = result.training_rmse;
  provenance.validation_metrics["rmse"] = result.validation_rmse;
  provenance.training_metrics["bias_before"] = result.bias_before;
  provenance.training_metrics["bias_after"] = result.bias_after;
  Eigen::MatrixXd curve(static_cast<Eigen::Index>(result.loss.size()), 3);
  for (std::size_t i = 0; i < result.loss.size(); ++i) {
    curve.row(static_cast<Eigen::Index>(i)) << result.loss[i].epoch, result.loss[i].training,
        result.loss[i].validation;
  }
  ensure_parent_folder(out);
  io::ModelFileWriter writer(out, provenance);
  io::write_mlp_input_estimator(writer, model, curve);
  writer.commit();

  nlohmann::json metrics;
  metrics["model_kind"] = io::kMlpInputEstimatorKind;
  metrics["model"] = out.string();
  metrics["config"] = config.name;
  metrics["seed"] = config.seed;
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
