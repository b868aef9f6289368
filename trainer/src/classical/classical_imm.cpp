// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/classical/classical_imm.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm/models/measurement/polar_measurement.hpp"
#include "imm/support/bounded_search.hpp"
#include "imm/tracking/tracker.hpp"
#include "imm/trainer/classical/noise_schedule.hpp"
#include "imm/trainer/learning_curve.hpp"
#include "imm/trainer/model_files/write_model.hpp"
#include "imm/trainer/normalized_errors.hpp"
#include "imm/trainer/parallel_for.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/training_config.hpp"

namespace imm::trainer::classical {
namespace {

constexpr double kLogLeaveLow = -4.0;                   // p = 1 − 10⁻⁴
constexpr double kLogLeaveHigh = -0.30102999566398120;  // p = 0.5

// The regime's scales: the largest commanded acceleration a (for a regime that never manoeuvres,
// the plots' σ over T²), the largest speed v (without one, a T) and ω_a = a/v, the turn rate at
// which the fastest target turns with a.
struct Scales {
  double a = 1.0, v = 1.0, omega = 1.0, T = 1.0;
};

Scales scales_of(const datasets::Regime& regime) {
  Scales s;
  s.T = regime.sample_period;
  s.a = regime.max_acceleration();
  if (!(s.a > 0.0)) s.a = regime.position_sigma() / (s.T * s.T);
  if (!(s.a > 0.0)) s.a = 1.0;
  s.v = regime.max_speed();
  if (!(s.v > 0.0)) s.v = s.a * s.T;
  // A turn rate beyond a quarter revolution per period is not a turn a filter can follow from
  // one plot to the next (nor one of 2π rad/s a target flies): the scale stops there.
  s.omega = std::min({s.a / s.v, 0.5 * std::numbers::pi / s.T, 2.0 * std::numbers::pi});
  return s;
}

// Dimensions of a mode set's search: one per CV or CA mode, two per CT mode, then the stay.
int dimensions(const ModeSet& modes) {
  int n = 1;
  for (const MotionKind m : modes) n += m == MotionKind::kCoordinatedTurn ? 2 : 1;
  return n;
}

}  // namespace

ModeSet mode_set_from(std::string_view text, const std::string& field) {
  ModeSet modes;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t end = std::min(text.find(',', start), text.size());
    std::string_view name = text.substr(start, end - start);
    while (!name.empty() && name.front() == ' ') name.remove_prefix(1);
    while (!name.empty() && name.back() == ' ') name.remove_suffix(1);
    const MotionKind kind = motion_kind_from(name, field);
    if (kind == MotionKind::kSinger) {
      throw InvalidParameter(field, "the classical IMM's modes are cv, ca and ct, not singer");
    }
    if (std::find(modes.begin(), modes.end(), kind) != modes.end()) {
      throw InvalidParameter(field, "mode '" + std::string(name) + "' appears twice");
    }
    modes.push_back(kind);
    start = end + 1;
  }
  if (modes.empty()) throw InvalidParameter(field, "names no mode");
  return modes;
}

std::string to_string(const ModeSet& modes) {
  std::string text;
  for (const MotionKind m : modes) {
    if (!text.empty()) text += ',';
    text += imm::to_string(m);
  }
  return text;
}

SearchBox search_box(const datasets::Regime& regime, const ModeSet& modes) {
  const Scales s = scales_of(regime);
  SearchBox box;
  const auto add = [&](double scale_squared, double low_decades) {
    box.lower.push_back(std::log10(scale_squared) - low_decades);
    box.upper.push_back(std::log10(scale_squared));
  };
  for (const MotionKind m : modes) {
    if (m == MotionKind::kConstantAcceleration) {
      add((s.a / s.T) * (s.a / s.T), 6.0);
    } else {
      add(s.a * s.a, 6.0);
      if (m == MotionKind::kCoordinatedTurn) {
        add(std::min((s.omega / s.T) * (s.omega / s.T), limits::kTurnRateNoise.max), 8.0);
      }
    }
  }
  box.lower.push_back(kLogLeaveLow);
  box.upper.push_back(kLogLeaveHigh);
  return box;
}

PlainImmSpec classical_spec(const datasets::Regime& regime, const ModeSet& modes,
                            const std::vector<double>& x) {
  if (static_cast<int>(x.size()) != dimensions(modes)) {
    throw InvalidParameter("x", "has " + std::to_string(x.size()) + " entries, the mode set " +
                                    to_string(modes) + " needs " +
                                    std::to_string(dimensions(modes)));
  }
  const Scales s = scales_of(regime);
  PlainImmSpec spec;
  spec.sample_period = regime.sample_period;
  std::size_t at = 0;
  for (const MotionKind m : modes) {
    ModeSpec mode;
    mode.name = std::string(imm::to_string(m));
    mode.motion = m;
    mode.process_noise = std::pow(10.0, x[at++]);
    if (m == MotionKind::kCoordinatedTurn) mode.turn_noise = std::pow(10.0, x[at++]);
    spec.modes.push_back(mode);
  }
  const auto n = static_cast<Eigen::Index>(modes.size());
  const double leave = std::pow(10.0, x[at]);
  spec.transition = Eigen::MatrixXd::Constant(n, n, n > 1 ? leave / static_cast<double>(n - 1) : 0);
  spec.transition.diagonal().setConstant(n > 1 ? 1.0 - leave : 1.0);
  spec.initial_probabilities = Eigen::VectorXd::Constant(n, 1.0 / static_cast<double>(n));
  if (regime.sensor.kind == datasets::SensorKind::kRangeSensor) {
    throw InvalidParameter("sensor.kind", "the classical IMM tracks Cartesian or polar plots");
  }
  if (regime.sensor.kind == datasets::SensorKind::kPolar && !regime.sensor.position.isZero()) {
    throw InvalidParameter("sensor.position",
                           "the classical IMM's polar plots are measured from the origin");
  }
  spec.measurement.kind = regime.sensor.kind == datasets::SensorKind::kPolar
                              ? MeasurementKind::kPolar
                              : MeasurementKind::kCartesian;
  spec.measurement.covariance = regime.sensor.noise.covariance();
  spec.initialization.method = InitializationMethod::kTwoPoint;
  spec.initialization.acceleration_variance = s.a * s.a;
  spec.initialization.turn_rate_variance =
      std::min(s.omega * s.omega, limits::kTurnRateVariance.max);
  spec.validate();
  return spec;
}

ClassicalScore score_classical(const PlainImmSpec& spec, const datasets::TrackSet& data) {
  if (std::abs(spec.sample_period - data.sample_period) > 1e-12 * data.sample_period) {
    throw InvalidParameter("sample_period", "differs from the tracks'");
  }
  const auto tracks = static_cast<long>(data.tracks.size());
  const int scans = data.scans;
  const bool truth = data.has_truth;
  // Per track and scan: ‖p − p̂‖², ‖p − z‖², ‖v − v̂‖², ‖v − v̄‖², a sample; and per track Σ −log p
  // and the number of plots, in the last row.
  constexpr int kWidth = 5;
  std::vector<Eigen::MatrixXd> terms(static_cast<std::size_t>(tracks));
  const double T = spec.sample_period;
  const TrackOptions options = spec.track_options();
  parallel_for(tracks, 1, [&](long t) {
    const datasets::Track& track = data.tracks[static_cast<std::size_t>(t)];
    Eigen::MatrixXd& m = terms[static_cast<std::size_t>(t)];
    m = Eigen::MatrixXd::Zero(scans + 1, kWidth);
    Tracker tracker(make_plain_imm_filter(spec), options);
    const int n = tracker.state_dimension();
    Eigen::VectorXd mean(n), variance(n);
    Eigen::Vector2d previous_plot = Eigen::Vector2d::Constant(std::nan(""));
    for (int k = 0; k < scans; ++k) {
      const Eigen::Vector2d z = track.plots.row(k).transpose();
      if (!z.allFinite()) {  // a recording's gap: the tracker predicts through it
        previous_plot.setConstant(std::nan(""));
        continue;
      }
      const TrackStepResult result = tracker.process(k, z);
      const Eigen::Vector2d plot =
          options.measurement_kind == MeasurementKind::kPolar
              ? polar_to_cartesian(z, options.measurement_covariance).position
              : z;
      const Eigen::Vector2d before = previous_plot;
      previous_plot = plot;
      if (result.event == TrackEvent::kRejected && result.status != StepStatus::kOk &&
          result.status != StepStatus::kInvalidMeasurement) {
        m(scans, 0) = std::numeric_limits<double>::infinity();  // a failed step: no score
        return;
      }
      if (result.event != TrackEvent::kUpdated) continue;
      m(scans, 0) -= tracker.filter().log_predictive_likelihood();
      m(scans, 1) += 1.0;
      // ζ's reference needs the measured velocity, (z(k) − z(k−1))/T: scans after a gap have none.
      if (!truth || !before.allFinite()) continue;
      tracker.state(mean, variance);
      const int y = n / 2;
      const Eigen::Vector2d p = datasets::position_at(track, k);
      const Eigen::Vector2d v = datasets::velocity_at(track, k);
      m(k, 0) = (p - Eigen::Vector2d(mean(0), mean(y))).squaredNorm();
      m(k, 1) = (p - plot).squaredNorm();
      m(k, 2) = (v - Eigen::Vector2d(mean(1), mean(y + 1))).squaredNorm();
      m(k, 3) = (v - (plot - before) / T).squaredNorm();
      m(k, 4) = 1.0;
    }
  });
  ClassicalScore score;
  Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(scans + 1, kWidth);
  for (const Eigen::MatrixXd& m : terms) sum += m;  // in track order: the same at any thread count
  const double nll = sum(scans, 0);
  score.plots = static_cast<long>(sum(scans, 1));
  const double entropy = kLogTwoPiE + 0.5 * std::log(spec.measurement.covariance.determinant());
  score.excess_nll = score.plots > 0 ? nll / static_cast<double>(score.plots) - entropy
                                     : std::numeric_limits<double>::infinity();
  if (truth) {
    const Eigen::VectorXd samples = sum.col(4).head(scans);
    score.zeta_p = mean_normalized_ratio(sum.col(0), sum.col(1), samples, scans);
    score.zeta_v = mean_normalized_ratio(sum.col(2), sum.col(3), samples, scans);
    score.objective = score.zeta_p + score.zeta_v;
  } else {
    score.objective = score.excess_nll;
  }
  if (!std::isfinite(score.objective)) score.objective = std::numeric_limits<double>::infinity();
  return score;
}

TunedClassicalImm tune_classical_imm(const ClassicalImmConfig& config,
                                     const datasets::TrackSet& training) {
  TunedClassicalImm best;
  best.score.objective = std::numeric_limits<double>::infinity();
  best.criterion = training.has_truth ? "zeta_p_plus_zeta_v" : "excess_nll";
  for (const ModeSet& modes : config.mode_sets) {
    const SearchBox box = search_box(config.regime, modes);
    const auto objective = [&](const std::vector<double>& x) {
      return score_classical(classical_spec(config.regime, modes, x), training).objective;
    };
    support::SearchOptions options;
    options.grid_points = config.grid_points;
    options.polish_evaluations = config.polish_evaluations;
    options.xtol_rel = 1e-3;
    const support::SearchResult found =
        support::grid_then_subplex(objective, box.lower, box.upper, options);
    best.evaluations += found.evaluations;
    best.tried.emplace_back(to_string(modes), found.value);
    if (found.value < best.score.objective) {
      best.spec = classical_spec(config.regime, modes, found.x);
      best.modes = modes;
      best.score = score_classical(best.spec, training);
    }
  }
  if (!std::isfinite(best.score.objective)) {
    throw std::runtime_error(
        "classical IMM: no mode set tracks the training split (every step "
        "failed); check the regime's sensor and sample period");
  }
  return best;
}

bool is_classical_config(const std::filesystem::path& path) {
  const auto document = support::ConfigDocument::load(path);
  return document->root().table("classical").has_value();
}

ClassicalImmConfig load_classical_config(const std::filesystem::path& path,
                                         const std::optional<std::filesystem::path>& regime) {
  return load_training_config<ClassicalImmConfig>(
      path,
      [](const support::ConfigTable& root, ClassicalImmConfig& config) {
        const auto table = root.table("classical");
        if (!table) root.fail("classical", "missing");
        if (table->has("mode_sets")) {
          config.mode_sets.clear();
          for (const std::string& set : table->texts("mode_sets")) {
            try {
              config.mode_sets.push_back(mode_set_from(set, table->path("mode_sets")));
            } catch (const InvalidParameter& error) {
              table->fail("mode_sets", error.message());
            }
          }
          if (config.mode_sets.empty()) table->fail("mode_sets", "names no mode set");
        }
        config.grid_points = table->count_or("grid_points", config.grid_points);
        if (config.grid_points < 2 || config.grid_points > 8) {
          table->fail("grid_points", "must be 2 to 8 (the grid has grid_points^dimensions points)");
        }
        config.polish_evaluations =
            table->count_or("polish_evaluations", config.polish_evaluations);
        if (config.polish_evaluations < 0 || config.polish_evaluations > 10000) {
          table->fail("polish_evaluations", "must be 0 to 10000 (0: the grid alone)");
        }
        if (const auto schedule = root.table("schedule")) {
          const int evaluations = schedule->count_or("evaluations", 400);
          if (evaluations < 1 || evaluations > 20000) {
            schedule->fail("evaluations", "must be 1 to 20000 (Subplex's budget)");
          }
          config.schedule_evaluations = evaluations;
        }
        if (config.regime.sensor.kind == datasets::SensorKind::kRangeSensor) {
          root.fail("regime",
                    "the classical IMM tracks Cartesian or polar plots, not a range "
                    "sensor's");
        }
      },
      regime);
}

ClassicalImmResult write_classical_imm(const ClassicalImmConfig& config,
                                       const std::filesystem::path& out) {
  const auto start = std::chrono::steady_clock::now();
  const datasets::TrackSet training =
      datasets::draw_split(config.regime, datasets::Split::kTraining, config.regime.splits.seed);
  ClassicalImmResult result;
  result.tuned = tune_classical_imm(config, training);
  const TunedClassicalImm& tuned = result.tuned;
  io::Provenance provenance = provenance_of(io::kPlainImmKind, config, training.digest());
  provenance.training_metrics["classical_baseline"] = 1.0;
  provenance.training_metrics["learned_part_on"] = 0.0;
  provenance.training_metrics[tuned.criterion] = tuned.score.objective;
  if (!training.has_truth) provenance.training_metrics["trained_without_truth"] = 1.0;
  const PlainImmSpec* written = &tuned.spec;
  if (config.schedule_evaluations) {
    const datasets::TrackSet validation = datasets::draw_split(
        config.regime, datasets::Split::kValidation, config.regime.splits.seed);
    result.schedule = std::make_shared<const LearnedSchedule>(
        learn_noise_schedule(tuned.spec, training, validation, *config.schedule_evaluations));
    const LearnedSchedule& schedule = *result.schedule;
    written = &schedule.spec;
    provenance.training_metrics["classical_baseline"] = 0.0;
    provenance.training_metrics["noise_schedule"] = 1.0;
    provenance.training_metrics["learned_part_on"] = schedule.on ? 1.0 : 0.0;
    provenance.training_metrics[tuned.criterion] =
        schedule.on ? schedule.training.objective : tuned.score.objective;
    if (!schedule.on) {
      result.small_split_warning = small_split_warning(
          "schedule", static_cast<int>(training.tracks.size()), config.regime.name);
    }
  }
  write_model_file(out, provenance,
                   [&](io::ModelFileWriter& writer) { io::write_plain_imm(writer, *written); });
  result.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  nlohmann::json metrics = metrics_of(io::kPlainImmKind, out, config.name);
  metrics["classical_baseline"] =
      "the CV/CA/CT IMM (coordinated turn as an EKF) tuned on the training split: modes, noise "
      "intensities and stay probability";
  metrics["regime"] = config.regime.name;
  metrics["modes"] = to_string(tuned.modes);
  nlohmann::json tried = nlohmann::json::object();
  for (const auto& [set, value] : tuned.tried) tried[set] = value;
  metrics["mode_sets_tried"] = tried;
  nlohmann::json modes = nlohmann::json::array();
  for (const ModeSpec& m : tuned.spec.modes) {
    nlohmann::json mode = {{"name", m.name}, {"process_noise", m.process_noise}};
    if (m.motion == MotionKind::kCoordinatedTurn) mode["turn_noise"] = m.turn_noise;
    modes.push_back(mode);
  }
  metrics["baseline"] = {{"modes", modes},
                         {"stay", tuned.spec.transition(0, 0)},
                         {"training_criterion", tuned.criterion},
                         {"training_objective", tuned.score.objective},
                         {"evaluations", tuned.evaluations}};
  if (result.schedule) {
    const LearnedSchedule& schedule = *result.schedule;
    metrics["classical_baseline"] = false;
    metrics["learned_part"] =
        "fuzzy noise schedules of every mode's Q, learned on top of the tuned IMM above";
    metrics["learned_part_on"] = schedule.on;
    metrics["noise_schedule"] = {{"evaluations", schedule.evaluations},
                                 {"training_base", schedule.training_base.objective},
                                 {"training", schedule.training.objective},
                                 {"validation_base", schedule.validation_base.objective},
                                 {"validation", schedule.validation.objective}};
    nlohmann::json tables = nlohmann::json::object();
    for (const ModeSpec& m : schedule.spec.modes) {
      if (!m.noise_schedule) continue;
      nlohmann::json w = nlohmann::json::array();
      for (const FuzzyRule& rule : m.noise_schedule->rules()) w.push_back(rule.w);
      tables[m.name] = w;
    }
    metrics["noise_schedule"]["multipliers"] = tables;
    if (!result.small_split_warning.empty()) metrics["warning"] = result.small_split_warning;
  }
  metrics["training_tracks"] = training.tracks.size();
  metrics["wall_seconds"] = result.wall_seconds;
  write_json_atomically(metrics_path(out), metrics);
  return result;
}

}  // namespace imm::trainer::classical
