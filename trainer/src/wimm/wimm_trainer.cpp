#include "imm/trainer/wimm/wimm_trainer.hpp"

#include <chrono>
#include <cmath>
#include <functional>
#include <numbers>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/datasets/random.hpp"
#include "imm/io/wimm_file.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/bounded_search.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/training_config.hpp"

namespace imm::trainer::wimm {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

WimmTrainingConfig config_from(const support::ConfigTable& root) {
  WimmTrainingConfig c;
  c.seed = root.seed_or("seed", 1);
  if (const auto f = root.table("filter")) {
    WimmSpec& s = c.filter;
    s.sample_period = f->real_or("sample_period", s.sample_period);
    s.cv_process_noise = f->real_or("cv_process_noise", s.cv_process_noise);
    s.singer_tau = f->real_or("singer_tau", s.singer_tau);
    s.singer_sigma = f->real_or("singer_sigma", s.singer_sigma);
    s.range_sigma = f->real_or("range_sigma", s.range_sigma);
    if (f->has("azimuth_sigma_deg")) {
      const double degrees = f->real("azimuth_sigma_deg");
      if (!(degrees >= 1e-6 && degrees <= 180.0)) {
        f->fail("azimuth_sigma_deg", "must be in [1e-06, 180]");
      }
      s.azimuth_sigma = degrees * kDegree;
    }
    if (f->has("transition")) s.transition = f->matrix("transition", 2, 2);
    if (f->has("initial_probabilities"))
      s.initial_probabilities = f->reals("initial_probabilities", 2);
    s.threshold = f->real_or("threshold", s.threshold);
    s.alpha = f->real_or("alpha", s.alpha);
    if (f->has("fusion")) s.fusion = fusion_variant_from(f->text("fusion"), f->path("fusion"));
    if (f->has("update")) s.update = measurement_update_from(f->text("update"), f->path("update"));
    s.acceleration_variance = f->real_or("acceleration_variance", s.acceleration_variance);
  }
  if (const auto t = root.table("training")) {
    WimmTrainingOptions& o = c.training;
    o.trajectories = t->count_or("trajectories", o.trajectories);
    o.steps = t->count_or("steps", o.steps);
    if (t->has("range_km")) {
      const Eigen::VectorXd r = t->reals("range_km", 2);
      o.min_range = r(0) * 1e3, o.max_range = r(1) * 1e3;
    }
    if (t->has("speed")) {
      const Eigen::VectorXd v = t->reals("speed", 2);
      o.min_speed = v(0), o.max_speed = v(1);
    }
    o.max_heading_offset_deg = t->real_or("max_heading_offset_deg", o.max_heading_offset_deg);
    o.max_turns = t->count_or("max_turns", o.max_turns);
    if (t->has("turn_rate_deg")) {
      const Eigen::VectorXd w = t->reals("turn_rate_deg", 2);
      o.min_turn_rate_deg = w(0), o.max_turn_rate_deg = w(1);
    }
    if (t->has("turn_scans")) {
      const Eigen::VectorXd d = t->reals("turn_scans", 2);
      o.min_turn_scans = static_cast<int>(d(0)), o.max_turn_scans = static_cast<int>(d(1));
    }
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
  }
  c.validate();
  return c;
}

Tuned tune(const WimmTrainingConfig& config, const TrainingScenarios& data,
           const std::function<WimmSpec(const std::vector<double>&)>& make,
           const std::vector<double>& lower, const std::vector<double>& upper) {
  WimmSpec reference_spec = config.filter;
  reference_spec.fusion = FusionVariant::kNone;
  const TrackingScore reference = score_tracking(reference_spec, data.scenario, data.data);
  auto f = [&](const std::vector<double>& x) {
    return objective(score_tracking(make(x), data.scenario, data.data), reference,
                     config.position_penalty);
  };
  const int grid = 6;
  const SearchResult search =
      grid_then_subplex(f, lower, upper,
                        {.grid_points = grid,
                         .polish_evaluations = std::max(0, config.max_evaluations - grid * grid),
                         .xtol_rel = 1e-3});
  Tuned tuned;
  tuned.spec = make(search.x);
  tuned.objective = search.value;
  tuned.evaluations = search.evaluations + 1;
  const TrackingScore score = score_tracking(tuned.spec, data.scenario, data.data);
  tuned.azimuth_ratio = score.azimuth_settled / reference.azimuth_settled;
  tuned.position_ratio = score.position_settled / reference.position_settled;
  return tuned;
}

}  // namespace

void WimmTrainingConfig::validate() const {
  try {
    filter.validate();
  } catch (const InvalidParameter& error) {
    throw error.within("filter.");
  }
  const WimmTrainingOptions& o = training;
  require(o.trajectories >= 1 && o.trajectories <= 10000, "training.trajectories",
          "must be in [1, 10000]");
  require(o.steps > kFirstSettledScan && o.steps <= 100000, "training.steps", "must exceed 40");
  require(o.min_range > 0.0 && o.max_range >= o.min_range && o.max_range <= limits::kDistance.max,
          "training.range_km", "must be 0 < min ≤ max ≤ 10⁶ km");
  require(o.min_speed > 0.0 && o.max_speed >= o.min_speed && o.max_speed <= limits::kSpeed.max,
          "training.speed", "must be 0 < min ≤ max ≤ 10⁶ m/s");
  require(o.max_heading_offset_deg >= 0.0 && o.max_heading_offset_deg <= 180.0,
          "training.max_heading_offset_deg", "must be in [0, 180]");
  require(o.max_turns >= 0 && o.max_turns <= 10, "training.max_turns", "must be in [0, 10]");
  require(o.min_turn_rate_deg > 0.0 && o.max_turn_rate_deg >= o.min_turn_rate_deg &&
              o.max_turn_rate_deg <= limits::kTurnRate.max,
          "training.turn_rate_deg", "must be 0 < min ≤ max ≤ 1000");
  require(
      o.min_turn_scans >= 1 && o.max_turn_scans >= o.min_turn_scans && o.max_turn_scans < o.steps,
      "training.turn_scans", "must be 1 ≤ min ≤ max < steps");
  require(min_threshold < max_threshold && min_threshold >= 0.0 && max_threshold <= 1.0,
          "tuning.threshold_range", "must be [min, max] within [0, 1], min < max");
  require(min_alpha > 0.0 && max_alpha <= 1.0 && min_alpha < max_alpha, "tuning.alpha_range",
          "must be [min, max] within (0, 1]");
  require(max_evaluations >= 1 && max_evaluations <= 1000000, "tuning.max_evaluations",
          "must be in [1, 10⁶]");
  limits::require_in(position_penalty, limits::kFactor, "tuning.position_penalty");
}

WimmTrainingConfig load_wimm_config(const std::filesystem::path& path) {
  return load_training_config<WimmTrainingConfig>(path, config_from);
}

TrainingScenarios make_training_scenarios(const WimmTrainingConfig& config) {
  const WimmTrainingOptions& o = config.training;
  TrainingScenarios result;
  datasets::ManeuverScenario& descriptor = result.scenario;
  descriptor.name = "wimm-training";
  descriptor.sample_period = config.filter.sample_period;
  descriptor.steps = o.steps;
  descriptor.runs = o.trajectories;
  descriptor.seed = config.seed;
  descriptor.measurement.kind = MeasurementKind::kPolar;
  descriptor.measurement.sigma =
      Eigen::Vector2d(config.filter.range_sigma, config.filter.azimuth_sigma);
  for (int t = 0; t < o.trajectories; ++t) {
    datasets::Rng rng(datasets::derive_seed(config.seed, 5000 + static_cast<std::uint64_t>(t)));
    datasets::ManeuverScenario s = descriptor;
    s.runs = 1;
    s.seed = datasets::derive_seed(config.seed, 7000 + static_cast<std::uint64_t>(t));
    const double range = rng.uniform(o.min_range, o.max_range);
    const double bearing = rng.uniform(0.0, 2.0 * std::numbers::pi);  // azimuth from north
    s.initial_position = range * Eigen::Vector2d(std::sin(bearing), std::cos(bearing));
    const double heading =
        bearing + std::numbers::pi +
        rng.uniform(-o.max_heading_offset_deg, o.max_heading_offset_deg) * kDegree;
    const double speed = rng.uniform(o.min_speed, o.max_speed);
    s.initial_velocity = speed * Eigen::Vector2d(std::sin(heading), std::cos(heading));
    const auto turns = static_cast<int>(rng.below(static_cast<std::uint64_t>(o.max_turns) + 1));
    for (int i = 0; i < turns; ++i) {
      const std::uint64_t span = static_cast<std::uint64_t>(o.max_turn_scans) -
                                 static_cast<std::uint64_t>(o.min_turn_scans) + 1;
      const int duration = o.min_turn_scans + static_cast<int>(rng.below(span));
      const int start = static_cast<int>(rng.below(static_cast<std::uint64_t>(o.steps - duration)));
      const double rate = rng.uniform(o.min_turn_rate_deg, o.max_turn_rate_deg) * kDegree;
      s.turns.push_back({start, start + duration, rng.uniform() < 0.5 ? -rate : rate});
    }
    result.data.append_first_run(datasets::simulate(s));
  }
  return result;
}

double objective(const TrackingScore& score, const TrackingScore& reference,
                 double position_penalty) {
  const double position_ratio = score.position_settled / reference.position_settled;
  const double value = score.azimuth_settled / reference.azimuth_settled +
                       position_penalty * std::max(0.0, position_ratio - 1.0);
  return std::isfinite(value) ? value : std::numeric_limits<double>::max();
}

Tuned tune_weighted_imm(const WimmTrainingConfig& config, const TrainingScenarios& data) {
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
  const TrainingScenarios data = make_training_scenarios(config);
  WimmTrainingResult result;
  result.tuned = tune_weighted_imm(config, data);
  result.digest = datasets::digest(data.data);
  result.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  io::Provenance provenance =
      make_provenance(std::string(io::kWimmKind), config.text,
                      static_cast<std::int64_t>(config.seed), result.digest);
  provenance.training_metrics["objective"] = result.tuned.objective;
  provenance.training_metrics["azimuth_ratio"] = result.tuned.azimuth_ratio;
  provenance.training_metrics["position_ratio"] = result.tuned.position_ratio;
  ensure_parent_folder(out);
  io::ModelFileWriter writer(out, provenance);
  io::write_wimm(writer, result.tuned.spec);
  writer.commit();

  nlohmann::json metrics;
  metrics["model_kind"] = io::kWimmKind;
  metrics["model"] = out.string();
  metrics["config"] = config.name;
  metrics["seed"] = config.seed;
  metrics["threshold"] = result.tuned.spec.threshold;
  metrics["alpha"] = result.tuned.spec.alpha;
  metrics["objective"] = result.tuned.objective;
  metrics["azimuth_ratio_settled"] = result.tuned.azimuth_ratio;
  metrics["position_ratio_settled"] = result.tuned.position_ratio;
  metrics["evaluations"] = result.tuned.evaluations;
  metrics["training_trajectories"] = config.training.trajectories;
  metrics["wall_seconds"] = result.wall_seconds;
  write_json_atomically(metrics_path(out), metrics);
  return result;
}

}  // namespace imm::trainer::wimm
