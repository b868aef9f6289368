// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/tsk/tsk_trainer.hpp"

#include <spdlog/spdlog.h>

#include <array>
#include <chrono>
#include <cmath>
#include <fstream>
#include <numeric>
#include <sstream>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/datasets/random.hpp"
#include "imm/datasets/range_sensor_file.hpp"
#include "imm/datasets/track.hpp"
#include "imm/estimation/mode_transitions.hpp"
#include "imm/io/file_error.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/model_files/write_model.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/regime_checks.hpp"
#include "imm/trainer/training_config.hpp"

namespace imm::trainer::tsk {
namespace {

// The config's own keys (config_on has read its regime and seed).
void fill(const support::ConfigTable& root, TskTrainingConfig& c) {
  require_sensor(c.regime, datasets::SensorKind::kRangeSensor, "a TSK sensor model");
  if (const auto f = root.table("fit")) {
    c.fcrm.clusters = f->count_or("rules", c.fcrm.clusters);
    c.fcrm.fuzzifier = f->real_or("fuzzifier", c.fcrm.fuzzifier);
    c.fcrm.tolerance = f->real_or("tolerance", c.fcrm.tolerance);
    c.fcrm.max_iterations = f->count_or("max_iterations", c.fcrm.max_iterations);
    c.fcrm.restarts = f->count_or("restarts", c.fcrm.restarts);
    if (f->has("t_norm")) c.t_norm = t_norm_from(f->text("t_norm"), f->path("t_norm"));
    c.fine_tuning.max_iterations =
        f->count_or("fine_tuning_iterations", c.fine_tuning.max_iterations);
    c.validation_fraction = f->real_or("validation_fraction", c.validation_fraction);
  }
  if (const auto g = root.table("gate")) {
    c.max_validation_rmse = g->real_or("max_validation_rmse", c.max_validation_rmse);
  }
  FimmSpec& s = c.fimm;
  s.sample_period = c.regime.sample_period;
  if (const auto f = root.table("fimm")) {
    s.cruise_sigma = f->real_or("cruise_sigma", s.cruise_sigma);
    s.lane_change_ratio = f->real_or("lane_change_ratio", s.lane_change_ratio);
    s.noise_scale = f->real_or("noise_scale", s.noise_scale);
    s.acceleration_variance = f->real_or("acceleration_variance", s.acceleration_variance);
    if (f->has("transition") && f->is_array("transition")) {
      s.transition = f->matrix("transition", 2, 2);
    } else if (f->has("transition")) {
      const std::string how = f->text("transition");
      if (how != "sojourns") {
        throw InvalidParameter(f->path("transition"),
                               "must be a 2 × 2 matrix or \"sojourns\" (learned from the "
                               "regime's training tracks), got \"" +
                                   how + "\"");
      }
      c.transitions_from_sojourns = true;
    }
    if (f->has("initial_probabilities")) {
      s.initial_probabilities = f->reals("initial_probabilities", 2);
    }
    c.iekf_iterations = f->count_or("iekf_iterations", c.iekf_iterations);
  }
  c.validate();
}

// "z1", "z2" (appended, not "z" + …: GCC 12 warns falsely on that form, bug 105329).
std::string output_key(int i) {
  std::string key = "z";
  key += std::to_string(i + 1);
  return key;
}

}  // namespace

void TskTrainingConfig::validate() const {
  require(validation_fraction > 0.0 && validation_fraction < 1.0, "fit.validation_fraction",
          "must be in (0, 1)");
  validate_within("fit.", fcrm);
  require(fine_tuning.max_iterations >= 0 && fine_tuning.max_iterations <= 100000,
          "fit.fine_tuning_iterations", "must be in [0, 100000]");
  require(max_validation_rmse > 0.0 && std::isfinite(max_validation_rmse),
          "gate.max_validation_rmse", "must be positive");
  validate_within("fimm.", fimm);
  require(iekf_iterations >= 2 && iekf_iterations <= 100, "fimm.iekf_iterations",
          "must be in [2, 100]");
}

TskTrainingConfig load_tsk_config(const std::filesystem::path& path,
                                  const std::optional<std::filesystem::path>& regime) {
  return load_training_config<TskTrainingConfig>(path, fill, regime);
}

SplitData split(const datasets::RangeSensorData& data, double validation_fraction,
                std::uint64_t seed) {
  const Eigen::Index n = data.positions.rows();
  std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), Eigen::Index{0});
  datasets::Rng rng(datasets::derive_seed(seed, 7));
  for (Eigen::Index i = n - 1; i > 0; --i) {  // Fisher–Yates with our own generator
    const auto j = static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(i) + 1));
    std::swap(order[static_cast<std::size_t>(i)], order[static_cast<std::size_t>(j)]);
  }
  const auto validation = std::max<Eigen::Index>(
      1, static_cast<Eigen::Index>(std::llround(validation_fraction * static_cast<double>(n))));
  const Eigen::Index training = n - validation;
  SplitData out;
  out.training_inputs.resize(training, 2);
  out.training_outputs.resize(training, 2);
  out.validation_inputs.resize(validation, 2);
  out.validation_outputs.resize(validation, 2);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Index q = order[static_cast<std::size_t>(i)];
    if (i < training) {
      out.training_inputs.row(i) = data.positions.row(q);
      out.training_outputs.row(i) = data.outputs.row(q);
    } else {
      out.validation_inputs.row(i - training) = data.positions.row(q);
      out.validation_outputs.row(i - training) = data.outputs.row(q);
    }
  }
  return out;
}

SensorSamples load_sensor_samples(const std::filesystem::path& path,
                                  const TskTrainingConfig& config) {
  SensorSamples samples{datasets::read_sensor_samples(path), path.string()};
  const datasets::Sensor& sensor = config.regime.sensor;
  if (!sensor.sampled || datasets::digest(samples.data) != sensor.samples_digest) {
    throw InvalidParameter(
        "regime",
        "the samples of " + path.string() + " are not the sensor of regime '" + config.regime.name +
            "': name them in the regime ([sensor] kind = \"range_sensor\", samples = \"" +
            path.string() + "\") so that the model is evaluated on the sensor it was fitted to");
  }
  return samples;
}

SensorSamples calibration_samples(const TskTrainingConfig& config) {
  const datasets::Sensor& sensor = config.regime.sensor;
  if (sensor.sampled) {
    return {datasets::read_sensor_samples(sensor.samples_file), sensor.samples_file};
  }
  return {datasets::draw_calibration(sensor, datasets::derive_seed(config.seed, 1)),
          "drawn from the sensor of regime " + config.regime.name};
}

TskTrainingResult train_tsk(const TskTrainingConfig& config, const std::filesystem::path& out) {
  return train_tsk(config, calibration_samples(config), out);
}

TskTrainingResult train_tsk(const TskTrainingConfig& config, const SensorSamples& samples,
                            const std::filesystem::path& out) {
  // The sensor model is fitted to the calibration samples the regime's sensor names, which carry
  // their positions; a recorded regime's tracks need no truth for it. The sojourns are read from
  // the training tracks' truth.
  if (config.transitions_from_sojourns) {
    require_training_truth(config.regime,
                           "the FIMM's mode transitions from the training tracks' "
                           "sojourns (fimm.transition = \"sojourns\")");
  }
  const auto start = std::chrono::steady_clock::now();
  const datasets::RangeSensorData& data = samples.data;
  const Eigen::Index n = data.positions.rows();
  if (n < 10 || data.positions.cols() != 2 || data.outputs.rows() != n ||
      data.outputs.cols() != 2 || !data.positions.allFinite() || !data.outputs.allFinite()) {
    throw io::FileError(samples.source, "", "need at least 10 finite samples (xi, eta, z1, z2)");
  }
  if (!((data.positions.colwise().maxCoeff() - data.positions.colwise().minCoeff()).array() > 0.0)
           .all()) {
    throw io::FileError(samples.source, "",
                        "the positions do not span a box (xi and eta must vary)");
  }
  const SplitData parts = split(data, config.validation_fraction, config.seed);
  TskTrainingResult result;
  result.training_samples = static_cast<int>(parts.training_inputs.rows());
  result.validation_samples = static_cast<int>(parts.validation_inputs.rows());
  result.digest = datasets::digest(data);

  std::array<TskOutput, 2> outputs;
  for (int i = 0; i < 2; ++i) {
    const Eigen::VectorXd z = parts.training_outputs.col(i);
    const Eigen::VectorXd z_validation = parts.validation_outputs.col(i);
    const FcrmResult clusters =
        fcrm(parts.training_inputs, z, config.fcrm, datasets::derive_seed(config.seed, 100 + i));
    std::vector<TskRule> rules =
        rules_from_clusters(parts.training_inputs, clusters, config.fcrm.fuzzifier);
    OutputReport& report = result.outputs[i];
    report.fcrm_objective = clusters.objective;
    report.fcrm_iterations = clusters.iterations;
    report.fcrm_training_rmse = rmse(rules, config.t_norm, parts.training_inputs, z);
    report.fcrm_validation_rmse = rmse(rules, config.t_norm, parts.validation_inputs, z_validation);
    report.fine_tuning =
        fine_tune(rules, config.t_norm, parts.training_inputs, z, config.fine_tuning);
    report.training_rmse = rmse(rules, config.t_norm, parts.training_inputs, z);
    report.validation_rmse = rmse(rules, config.t_norm, parts.validation_inputs, z_validation);
    report.sigma = report.training_rmse;  // eq. (7)
    spdlog::info(
        "tsk: output z{}: FCRM {} restarts, objective {:.4g}, RMSE {:.4f} / {:.4f} m (training / "
        "validation); fine tuning {} iterations: RMSE {:.4f} / {:.4f} m, sigma {:.4f}",
        i + 1, clusters.restarts, clusters.objective, report.fcrm_training_rmse,
        report.fcrm_validation_rmse, report.fine_tuning.iterations, report.training_rmse,
        report.validation_rmse, report.sigma);
    outputs[static_cast<std::size_t>(i)].rules = std::move(rules);
    outputs[static_cast<std::size_t>(i)].sigma = report.sigma;
  }
  result.model = TskSensorModel(std::move(outputs), config.t_norm,
                                parts.training_inputs.colwise().minCoeff().transpose(),
                                parts.training_inputs.colwise().maxCoeff().transpose());
  result.gate_passed = true;
  for (const OutputReport& r : result.outputs) {
    result.gate_passed = result.gate_passed && r.validation_rmse <= config.max_validation_rmse &&
                         std::isfinite(r.validation_rmse);
  }
  // The FIMM as imm-eval fimm runs it (the EKF), with the regime's first case's plot noise: what
  // a tracking application loads (imm::load_filter) without the training config.
  result.fimm = config.fimm;
  result.fimm.measurement_covariance = config.regime.noise_of(0).covariance();
  if (config.transitions_from_sojourns) {
    const datasets::TrackSet tracks =
        datasets::draw_split(config.regime, datasets::Split::kTraining, 0);
    result.sojourns = estimate_maneuver_sojourns(tracks);
    result.fimm.transition = transition_matrix(result.sojourns->generator, tracks.sample_period);
    const SojournEstimate& e = *result.sojourns;
    spdlog::info(
        "tsk: FIMM mode transitions from {} training tracks: mean sojourn cruise {:.3g} ± {:.2g} "
        "s ({} exits), lane change {:.3g} ± {:.2g} s ({} exits); P(stay) {:.5f} / {:.5f} at T = "
        "{} s",
        tracks.tracks.size(), e.mean_sojourn(0), e.standard_error(0), e.exits(0), e.mean_sojourn(1),
        e.standard_error(1), e.exits(1), result.fimm.transition(0, 0), result.fimm.transition(1, 1),
        tracks.sample_period);
  }
  result.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  nlohmann::json metrics = metrics_of(io::kTskSensorKind, out, config.name);
  metrics["regime"] = {{"name", config.regime.name}, {"digest", config.regime.digest}};
  metrics["data"] = samples.source;
  metrics["seed"] = config.seed;
  metrics["samples"] = {{"training", result.training_samples},
                        {"validation", result.validation_samples}};
  metrics["t_norm"] = std::string(to_string(config.t_norm));
  metrics["rules"] = config.fcrm.clusters;
  for (int i = 0; i < 2; ++i) {
    const OutputReport& r = result.outputs[i];
    metrics["outputs"][output_key(i)] = {{"fcrm_training_rmse", r.fcrm_training_rmse},
                                         {"fcrm_validation_rmse", r.fcrm_validation_rmse},
                                         {"training_rmse", r.training_rmse},
                                         {"validation_rmse", r.validation_rmse},
                                         {"sigma", r.sigma},
                                         {"fcrm_objective", r.fcrm_objective},
                                         {"fcrm_iterations", r.fcrm_iterations},
                                         {"fine_tuning_iterations", r.fine_tuning.iterations}};
  }
  metrics["fimm_transition"] = {
      {"source", config.transitions_from_sojourns ? "sojourns" : "config"},
      {"stay", {result.fimm.transition(0, 0), result.fimm.transition(1, 1)}}};
  if (result.sojourns) {
    metrics["fimm_transition"]["mean_sojourn_s"] = {result.sojourns->mean_sojourn(0),
                                                    result.sojourns->mean_sojourn(1)};
    metrics["fimm_transition"]["standard_error_s"] = {result.sojourns->standard_error(0),
                                                      result.sojourns->standard_error(1)};
  }
  metrics["wall_seconds"] = result.wall_seconds;
  metrics["gate"] = {{"max_validation_rmse", config.max_validation_rmse},
                     {"passed", result.gate_passed}};
  ensure_parent_folder(out);
  write_json_atomically(metrics_path(out), metrics);
  if (!result.gate_passed) return result;

  io::Provenance provenance = provenance_of(io::kTskSensorKind, config, result.digest);
  for (int i = 0; i < 2; ++i) {
    const std::string key = output_key(i);
    provenance.training_metrics[key + "_rmse"] = result.outputs[i].training_rmse;
    provenance.training_metrics[key + "_fcrm_rmse"] = result.outputs[i].fcrm_training_rmse;
    provenance.validation_metrics[key + "_rmse"] = result.outputs[i].validation_rmse;
    provenance.validation_metrics[key + "_fcrm_rmse"] = result.outputs[i].fcrm_validation_rmse;
  }
  if (result.sojourns) {
    provenance.training_metrics["cruise_sojourn_s"] = result.sojourns->mean_sojourn(0);
    provenance.training_metrics["lane_change_sojourn_s"] = result.sojourns->mean_sojourn(1);
  }
  write_model_file(out, provenance, [&](io::ModelFileWriter& writer) {
    io::write_tsk_sensor(writer, result.model);
    io::write_fimm_settings(writer, result.fimm);
  });
  return result;
}

}  // namespace imm::trainer::tsk
