#include "imm/trainer/fcm/fcm_trainer.hpp"

#include <omp.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/datasets/random.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/bounded_search.hpp"
#include "imm/trainer/parallel_for.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/training_config.hpp"

namespace imm::trainer::fcm {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;
constexpr int kFirstScoredScan = 2;

std::pair<double, double> range(const support::ConfigTable& t, std::string_view key,
                                std::pair<double, double> fallback) {
  if (!t.has(key)) return fallback;
  const Eigen::VectorXd r = t.reals(key, 2);
  return {r(0), r(1)};
}

FcmTrainingConfig config_from(const support::ConfigTable& root) {
  FcmTrainingConfig c;
  c.seed = root.seed_or("seed", 1);
  if (const auto f = root.table("filter")) {
    FcmImmSpec& s = c.filter;
    s.sample_period = f->real_or("sample_period", s.sample_period);
    s.measurement_sigma = f->real_or("measurement_sigma", s.measurement_sigma);
    const std::int64_t modes = f->integer_or("modes", 3);
    if (modes < 1 || modes > 8) f->fail("modes", "must be in [1, 8]");
    if (f->has("process_noise")) {
      const Eigen::VectorXd q = f->reals("process_noise", modes);
      s.process_noise.assign(q.data(), q.data() + q.size());
    } else {
      s.process_noise.clear();
      for (std::int64_t j = 0; j < modes; ++j) {
        s.process_noise.push_back(
            std::pow(10.0, 4.0 * static_cast<double>(j) /
                               static_cast<double>(std::max<std::int64_t>(1, modes - 1))));
      }
    }
    const double stay = f->real_or("stay", 0.95);
    if (!(stay > 0.0 && stay <= 1.0)) f->fail("stay", "must be in (0, 1]");
    s.transition = FcmImmSpec::switching_transition(static_cast<int>(modes), stay);
    c.initial_first_probability =
        f->real_or("initial_first_probability", c.initial_first_probability);
    if (!(c.initial_first_probability >= 0.0 && c.initial_first_probability <= 1.0)) {
      f->fail("initial_first_probability", "must be in [0, 1]");
    }
    AxisImmSettings settings;
    settings.initial_first_probability = c.initial_first_probability;
    s.initial_probabilities = settings.initial_probabilities(static_cast<int>(modes));
    if (f->has("membership_scale")) {
      s.scale = membership_scale_from(f->text("membership_scale"), f->path("membership_scale"));
    }
    s.compensate_lowest = f->boolean_or("compensate_lowest", s.compensate_lowest);
    s.window = f->count_or("window", s.window);
    s.clustering.fuzzifier = f->real_or("fuzzifier", s.clustering.fuzzifier);
    s.clustering.tolerance = f->real_or("tolerance", s.clustering.tolerance);
    s.clustering.max_iterations = f->count_or("max_iterations", s.clustering.max_iterations);
    s.separation = f->real_or("separation", s.separation);
    s.compensation_gain = f->real_or("compensation_gain", s.compensation_gain);
  }
  if (const auto t = root.table("training")) {
    FcmTrainingOptions& o = c.training;
    o.trajectories = t->count_or("trajectories", o.trajectories);
    o.validation = t->count_or("validation", o.validation);
    o.steps = t->count_or("steps", o.steps);
    auto [r0, r1] = range(*t, "range_km", {o.min_range / 1e3, o.max_range / 1e3});
    o.min_range = r0 * 1e3, o.max_range = r1 * 1e3;
    std::tie(o.min_speed, o.max_speed) = range(*t, "speed", {o.min_speed, o.max_speed});
    o.max_heading_offset_deg = t->real_or("max_heading_offset_deg", o.max_heading_offset_deg);
    std::tie(o.min_acceleration, o.max_acceleration) =
        range(*t, "acceleration", {o.min_acceleration, o.max_acceleration});
    auto [q0, q1] = range(*t, "quarter", {o.min_quarter, o.max_quarter});
    o.min_quarter = static_cast<int>(q0), o.max_quarter = static_cast<int>(q1);
    auto [p0, p1] = range(*t, "periods", {o.min_periods, o.max_periods});
    o.min_periods = static_cast<int>(p0), o.max_periods = static_cast<int>(p1);
    o.maneuver_probability = t->real_or("maneuver_probability", o.maneuver_probability);
    o.process_noise_sigma = t->real_or("process_noise_sigma", o.process_noise_sigma);
  }
  if (const auto u = root.table("tuning")) {
    FcmTuning& g = c.tuning;
    if (u->has("windows")) {
      const Eigen::VectorXd w = u->reals("windows");
      g.windows.clear();
      for (double v : w) {
        if (v != std::floor(v)) u->fail("windows", "must be integers");
        g.windows.push_back(static_cast<int>(v));
      }
    }
    std::tie(g.min_log_q, g.max_log_q) = range(*u, "log10_q", {g.min_log_q, g.max_log_q});
    std::tie(g.min_stay, g.max_stay) = range(*u, "stay", {g.min_stay, g.max_stay});
    std::tie(g.min_gain, g.max_gain) = range(*u, "compensation_gain", {g.min_gain, g.max_gain});
    std::tie(g.min_fuzzifier, g.max_fuzzifier) =
        range(*u, "fuzzifier", {g.min_fuzzifier, g.max_fuzzifier});
    std::tie(g.min_separation, g.max_separation) =
        range(*u, "separation", {g.min_separation, g.max_separation});
    g.max_evaluations = u->count_or("max_evaluations", g.max_evaluations);
  }
  if (const auto g = root.table("gate")) {
    c.max_validation_ratio = g->real_or("max_validation_ratio", c.max_validation_ratio);
  }
  c.validate();
  return c;
}

// The per-axis Gaussian of the two-point start from plots z0, z1.
GaussianState<2> two_point(double z0, double z1, double T, double r) {
  GaussianState<2> s;
  s.mean << z1, (z1 - z0) / T;
  s.covariance << r, r / T, r / T, 2.0 * r / (T * T);
  return s;
}

struct RunErrors {
  double position = 0.0, velocity = 0.0;  // sums of squared errors
  long scans = 0;
  bool failed = false;
};

// log10 q → q for the modes from x = [log q₁, Δ₂, …, Δ_n]: ascending by construction.
std::vector<double> noise_levels(const std::vector<double>& x, int n, double max_log_q) {
  std::vector<double> q;
  double log_q = x[0];
  for (int j = 0; j < n; ++j) {
    if (j > 0) log_q = std::min(max_log_q, log_q + x[static_cast<std::size_t>(j)]);
    q.push_back(std::pow(10.0, log_q));
  }
  return q;
}

}  // namespace

void FcmTrainingConfig::validate() const {
  try {
    filter.validate();
  } catch (const InvalidParameter& error) {
    // The spec's field names, in the config's vocabulary.
    std::string key = error.field();
    if (key.rfind("clustering.", 0) == 0) key = key.substr(std::string("clustering.").size());
    if (key.rfind("process_noise", 0) == 0) key = "process_noise";
    if (key == "transition") key = "stay";
    if (key == "initial_probabilities") key = "initial_first_probability";
    throw InvalidParameter("filter." + key, error.message());
  }
  const FcmTrainingOptions& o = training;
  require(o.trajectories >= 1 && o.trajectories <= 10000, "training.trajectories",
          "must be in [1, 10000]");
  require(o.validation >= 1 && o.validation <= 10000, "training.validation",
          "must be in [1, 10000]");
  require(o.steps >= 20 && o.steps <= 100000, "training.steps", "must be in [20, 100000]");
  require(o.min_range > 0.0 && o.max_range >= o.min_range && o.max_range <= limits::kDistance.max,
          "training.range_km", "must be 0 < min ≤ max ≤ 10⁶ km");
  require(o.min_speed > 0.0 && o.max_speed >= o.min_speed && o.max_speed <= limits::kSpeed.max,
          "training.speed", "must be 0 < min ≤ max ≤ 10⁶ m/s");
  require(o.max_heading_offset_deg >= 0.0 && o.max_heading_offset_deg <= 180.0,
          "training.max_heading_offset_deg", "must be in [0, 180]");
  require(o.min_acceleration >= 0.0 && o.max_acceleration >= o.min_acceleration &&
              o.max_acceleration <= limits::kAcceleration.max,
          "training.acceleration", "must be 0 ≤ min ≤ max ≤ 10⁶ m/s²");
  require(o.min_quarter >= 1 && o.max_quarter >= o.min_quarter, "training.quarter",
          "must be 1 ≤ min ≤ max");
  require(o.min_periods >= 1 && o.max_periods >= o.min_periods, "training.periods",
          "must be 1 ≤ min ≤ max");
  require(4 * o.max_quarter * o.max_periods < o.steps, "training.periods",
          "the longest zigzag must fit in the steps");
  require(o.maneuver_probability >= 0.0 && o.maneuver_probability <= 1.0,
          "training.maneuver_probability", "must be in [0, 1]");
  limits::require_in(o.process_noise_sigma, limits::kAcceleration, "training.process_noise_sigma");
  const FcmTuning& g = tuning;
  require(!g.windows.empty() && g.windows.size() <= 16, "tuning.windows", "need 1 to 16 windows");
  for (int w : g.windows) {
    require(w >= 3 && w <= SlidingFuzzyCMeans::kMaxWindow, "tuning.windows",
            "every window must be in [3, " + std::to_string(SlidingFuzzyCMeans::kMaxWindow) + "]");
  }
  // q = 10^x must stay a variance in range (imm/core/physical_limits.hpp).
  require(g.min_log_q >= -30.0 && g.max_log_q <= 18.0 && g.min_log_q < g.max_log_q,
          "tuning.log10_q", "must be [min, max] within [-30, 18], min < max");
  require(g.min_stay > 0.0 && g.max_stay <= 1.0 && g.min_stay < g.max_stay, "tuning.stay",
          "must be [min, max] within (0, 1]");
  require(g.min_gain >= 0.0 && g.max_gain <= 1.0 && g.min_gain <= g.max_gain,
          "tuning.compensation_gain", "must be [min, max] within [0, 1]");
  require(g.min_fuzzifier >= 1.01 && g.max_fuzzifier >= g.min_fuzzifier && g.max_fuzzifier <= 100.0,
          "tuning.fuzzifier", "must be [min, max] with 1.01 ≤ min ≤ max ≤ 100");
  require(g.min_separation >= 0.0 && g.max_separation >= g.min_separation &&
              g.max_separation <= limits::kFactor.max,
          "tuning.separation", "must be [min, max] with 0 ≤ min ≤ max ≤ 10⁶");
  require(g.max_evaluations >= 0 && g.max_evaluations <= 100000, "tuning.max_evaluations",
          "must be in [0, 100000]");
  require(max_validation_ratio > 0.0 && std::isfinite(max_validation_ratio),
          "gate.max_validation_ratio", "must be positive");
}

FcmTrainingConfig load_fcm_config(const std::filesystem::path& path) {
  return load_training_config<FcmTrainingConfig>(path, config_from);
}

TrackingData make_trajectories(const FcmTrainingConfig& config, bool validation) {
  const FcmTrainingOptions& o = config.training;
  const int count = validation ? o.validation : o.trajectories;
  // Disjoint random streams for training (10000 + t) and validation (20000 + t); the evaluation
  // scenario uses its own seed and a fixed geometry.
  const std::uint64_t base = validation ? 20000 : 10000;
  TrackingData result;
  datasets::ManeuverScenario& descriptor = result.scenario;
  descriptor.name = validation ? "fcm-validation" : "fcm-training";
  descriptor.sample_period = config.filter.sample_period;
  descriptor.steps = o.steps;
  descriptor.runs = count;
  descriptor.seed = config.seed;
  descriptor.process_noise_sigma = o.process_noise_sigma;
  descriptor.measurement.kind = MeasurementKind::kCartesian;
  descriptor.measurement.sigma = Eigen::Vector2d::Constant(config.filter.measurement_sigma);
  for (int t = 0; t < count; ++t) {
    datasets::Rng rng(datasets::derive_seed(config.seed, base + static_cast<std::uint64_t>(t)));
    datasets::ManeuverScenario s = descriptor;
    s.runs = 1;
    s.seed = datasets::derive_seed(config.seed, base + 5000 + static_cast<std::uint64_t>(t));
    const double distance = rng.uniform(o.min_range, o.max_range);
    const double bearing = rng.uniform(0.0, 2.0 * std::numbers::pi);
    s.initial_position = distance * Eigen::Vector2d(std::sin(bearing), std::cos(bearing));
    const double heading =
        bearing + std::numbers::pi +
        rng.uniform(-o.max_heading_offset_deg, o.max_heading_offset_deg) * kDegree;
    const Eigen::Vector2d direction(std::sin(heading), std::cos(heading));
    s.initial_velocity = rng.uniform(o.min_speed, o.max_speed) * direction;
    if (rng.uniform() < o.maneuver_probability) {
      const int quarter =
          o.min_quarter + static_cast<int>(rng.below(
                              static_cast<std::uint64_t>(o.max_quarter - o.min_quarter) + 1));
      const int periods =
          o.min_periods + static_cast<int>(rng.below(
                              static_cast<std::uint64_t>(o.max_periods - o.min_periods) + 1));
      std::vector<double> magnitudes;
      magnitudes.reserve(static_cast<std::size_t>(periods));
      for (int i = 0; i < periods; ++i) {
        magnitudes.push_back(rng.uniform(o.min_acceleration, o.max_acceleration));
      }
      const int length = 4 * quarter * periods;
      const int start = kFirstScoredScan + 8 +
                        static_cast<int>(rng.below(static_cast<std::uint64_t>(
                            std::max(1, o.steps - length - kFirstScoredScan - 8))));
      const Eigen::Vector2d lateral =
          (rng.uniform() < 0.5 ? 1.0 : -1.0) * Eigen::Vector2d(-direction.y(), direction.x());
      s.maneuvers = datasets::zigzag_maneuvers(start, quarter, magnitudes, lateral);
    }
    result.data.append_first_run(datasets::simulate(s));
  }
  return result;
}

TrackingScore score_filter(const FilterFactory& make, const TrackingData& data,
                           double measurement_sigma) {
  const double T = data.scenario.sample_period;
  const double r = measurement_sigma * measurement_sigma;
  const int runs = static_cast<int>(data.data.truth.size());
  std::vector<RunErrors> errors(static_cast<std::size_t>(runs));
  parallel_for(runs, 1, [&](long run) {
    RunErrors& e = errors[static_cast<std::size_t>(run)];
    const Eigen::MatrixXd& x = data.data.truth[static_cast<std::size_t>(run)];
    const Eigen::MatrixXd& z = data.data.measurements[static_cast<std::size_t>(run)];
    std::unique_ptr<TwoAxisFilter> filter = make();
    Eigen::VectorXd mean(4);
    Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(4, 4);
    for (Eigen::Index axis = 0; axis < 2; ++axis) {
      const GaussianState<2> s = two_point(z(0, axis), z(1, axis), T, r);
      mean.segment<2>(2 * axis) = s.mean;
      covariance.block<2, 2>(2 * axis, 2 * axis) = s.covariance;
    }
    filter->initialize(mean, covariance);
    Eigen::VectorXd estimate(4), variance(4);
    for (Eigen::Index k = kFirstScoredScan; k < z.rows(); ++k) {
      if (filter->step(z.row(k).transpose()) != StepStatus::kOk) {
        e.failed = true;
        break;
      }
      filter->state(estimate, variance);
      const double dx = estimate(0) - x(k, 0), dy = estimate(2) - x(k, 2);
      const double dvx = estimate(1) - x(k, 1), dvy = estimate(3) - x(k, 3);
      e.position += dx * dx + dy * dy;
      e.velocity += dvx * dvx + dvy * dvy;
      ++e.scans;
    }
  });
  // Summed in run order: the same result for any thread count.
  double position = 0.0, velocity = 0.0;
  long scans = 0;
  for (const RunErrors& e : errors) {
    if (e.failed) {
      return {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
              std::numeric_limits<double>::infinity()};
    }
    position += e.position;
    velocity += e.velocity;
    scans += e.scans;
  }
  TrackingScore score;
  score.position_rmse = std::sqrt(position / static_cast<double>(std::max(1L, scans)));
  score.velocity_rmse = std::sqrt(velocity / static_cast<double>(std::max(1L, scans)));
  score.objective = (score.position_rmse + T * score.velocity_rmse) / measurement_sigma;
  if (!std::isfinite(score.objective)) score.objective = std::numeric_limits<double>::infinity();
  return score;
}

namespace {

AxisImmSettings axis_settings(const FcmTrainingConfig& config, double stay) {
  AxisImmSettings s;
  s.sample_period = config.filter.sample_period;
  s.measurement_sigma = config.filter.measurement_sigma;
  s.transition_stay = stay;
  s.initial_first_probability = config.initial_first_probability;
  return s;
}

AxisCvImmSpec cv_imm_spec(const FcmTrainingConfig& config, const std::vector<double>& q,
                          double stay) {
  AxisCvImmSpec spec;
  spec.settings = axis_settings(config, stay);
  spec.process_noise = q;
  return spec;
}

}  // namespace

Tuned<AxisCvImmSpec> tune_kf(const FcmTrainingConfig& config, const TrackingData& data) {
  const FcmTuning& g = config.tuning;
  auto make = [&](const std::vector<double>& x) {
    return cv_imm_spec(config, {std::pow(10.0, x[0])}, 1.0);
  };
  const SearchResult search = grid_then_subplex(
      [&](const std::vector<double>& x) {
        const AxisCvImmSpec spec = make(x);
        return score_filter([&] { return make_axis_cv_imm_filter(spec); }, data,
                            config.filter.measurement_sigma)
            .objective;
      },
      {g.min_log_q}, {g.max_log_q},
      {.grid_points = 14, .polish_evaluations = 30, .xtol_abs = 1e-3});
  Tuned<AxisCvImmSpec> tuned;
  tuned.spec = make(search.x);
  tuned.score = score_filter([&] { return make_axis_cv_imm_filter(tuned.spec); }, data,
                             config.filter.measurement_sigma);
  tuned.evaluations = search.evaluations + 1;
  return tuned;
}

Tuned<AxisCvImmSpec> tune_cv_imm(const FcmTrainingConfig& config, const TrackingData& data) {
  const FcmTuning& g = config.tuning;
  const int n = config.filter.mode_count();
  const double sigma = config.filter.measurement_sigma;
  // Stage 1: an ordered grid over the log q_j at the config's stay probability.
  const double stay = config.filter.transition(0, 0);
  const SearchResult grid = grid_then_subplex(
      [&](const std::vector<double>& log_q) {
        std::vector<double> q;
        q.reserve(log_q.size());
        for (double e : log_q) q.push_back(std::pow(10.0, e));
        const AxisCvImmSpec spec = cv_imm_spec(config, q, stay);
        return score_filter([&] { return make_axis_cv_imm_filter(spec); }, data, sigma).objective;
      },
      std::vector<double>(static_cast<std::size_t>(n), g.min_log_q),
      std::vector<double>(static_cast<std::size_t>(n), g.max_log_q),
      {.grid_points = n <= 3 ? 6 : 4, .polish_evaluations = 0, .ordered = true});
  // Stage 2: Subplex over [log q₁, Δ₂ …, stay] from there.
  std::vector<double> x0 = {grid.x[0]};
  for (int j = 1; j < n; ++j) {
    x0.push_back(grid.x[static_cast<std::size_t>(j)] - grid.x[static_cast<std::size_t>(j - 1)]);
  }
  x0.push_back(std::clamp(stay, g.min_stay, g.max_stay));
  std::vector<double> lower = {g.min_log_q}, upper = {g.max_log_q};
  for (int j = 1; j < n; ++j) lower.push_back(0.0), upper.push_back(g.max_log_q - g.min_log_q);
  lower.push_back(g.min_stay), upper.push_back(g.max_stay);
  auto make = [&](const std::vector<double>& x) {
    return cv_imm_spec(config, noise_levels(x, n, g.max_log_q), x.back());
  };
  const SearchResult polished = subplex(
      [&](const std::vector<double>& x) {
        const AxisCvImmSpec spec = make(x);
        return score_filter([&] { return make_axis_cv_imm_filter(spec); }, data, sigma).objective;
      },
      x0, lower, upper, 40 * (n + 1), 1e-3);
  Tuned<AxisCvImmSpec> tuned;
  tuned.spec = make(polished.x);
  tuned.score = score_filter([&] { return make_axis_cv_imm_filter(tuned.spec); }, data, sigma);
  tuned.evaluations = grid.evaluations + polished.evaluations + 1;
  return tuned;
}

Tuned<AimmSpec> tune_aimm(const FcmTrainingConfig& config, const TrackingData& data) {
  const double sigma = config.filter.measurement_sigma;
  // x = log10 [ε, σ_w, σ_b] in m/s².
  auto make = [&](const std::vector<double>& x) {
    AimmSpec spec;
    spec.settings = axis_settings(config, 0.97);
    spec.intervals = {std::pow(10.0, x[0])};
    spec.process_noise_sigma = std::pow(10.0, x[1]);
    spec.bias_noise_sigma = std::pow(10.0, x[2]);
    spec.acceleration_variance = 100.0;
    return spec;
  };
  const SearchResult search = grid_then_subplex(
      [&](const std::vector<double>& x) {
        const AimmSpec spec = make(x);
        return score_filter([&] { return make_aimm_filter(spec); }, data, sigma).objective;
      },
      {0.0, -1.0, -1.0}, {2.5, 2.0, 2.0},
      {.grid_points = 5, .polish_evaluations = 80, .xtol_abs = 1e-3});
  Tuned<AimmSpec> tuned;
  tuned.spec = make(search.x);
  tuned.score = score_filter([&] { return make_aimm_filter(tuned.spec); }, data, sigma);
  tuned.evaluations = search.evaluations + 1;
  return tuned;
}

FcmImmSpec fcm_spec_from(const FcmTrainingConfig& config, const AxisCvImmSpec& imm) {
  FcmImmSpec spec = config.filter;
  spec.process_noise = imm.process_noise;
  const int n = static_cast<int>(imm.process_noise.size());
  spec.transition = imm.settings.transition(n);
  spec.initial_probabilities = imm.settings.initial_probabilities(n);
  spec.compensation_gain = 0.0;
  return spec;
}

Eigen::MatrixXd mean_memberships(const FcmImmSpec& spec, const TrackingData& data) {
  const int n = spec.mode_count();
  const double T = spec.sample_period;
  const double r = spec.measurement_sigma * spec.measurement_sigma;
  Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(n, kFcmClusters);
  long samples = 0;
  for (const Eigen::MatrixXd& z : data.data.measurements) {
    for (int axis = 0; axis < 2; ++axis) {
      FcmImmAxisFilter filter(spec);
      filter.initialize(two_point(z(0, axis), z(1, axis), T, r));
      for (Eigen::Index k = kFirstScoredScan; k < z.rows(); ++k) {
        if (filter.step(z(k, axis)) != StepStatus::kOk) continue;
        for (int j = 0; j < n; ++j) sum.row(j) += filter.mode(j).memberships().transpose();
        ++samples;
      }
    }
  }
  if (samples == 0) throw std::runtime_error("mean memberships: no step succeeded");
  Eigen::MatrixXd mean = sum / static_cast<double>(samples);
  for (int j = 0; j < n; ++j) mean.row(j) /= mean.row(j).sum();  // exact unit rows
  return mean;
}

FcmTrainingResult train_fcm(const FcmTrainingConfig& config, const std::filesystem::path& out) {
  const auto start = std::chrono::steady_clock::now();
  const TrackingData training = make_trajectories(config, false);
  const TrackingData validation = make_trajectories(config, true);
  const double sigma = config.filter.measurement_sigma;
  const FcmTuning& g = config.tuning;
  const int n = config.filter.mode_count();
  FcmTrainingResult result;

  // The constant-q IMM: the starting point, and the λ = 0 member of the family.
  const Tuned<AxisCvImmSpec> imm = tune_cv_imm(config, training);
  result.evaluations += imm.evaluations;
  const FcmImmSpec base = fcm_spec_from(config, imm.spec);
  result.imm_training = imm.score;
  result.imm_validation =
      score_filter([&] { return make_axis_cv_imm_filter(imm.spec); }, validation, sigma);
  spdlog::info(
      "fcm: constant-q IMM (lambda = 0): J = {:.4f} training, {:.4f} validation ({} "
      "evaluations)",
      imm.score.objective, result.imm_validation.objective, imm.evaluations);

  // x = [log q₁, Δ₂ …, stay, λ, m, κ].
  std::vector<double> lower = {g.min_log_q}, upper = {g.max_log_q};
  for (int j = 1; j < n; ++j) lower.push_back(0.0), upper.push_back(g.max_log_q - g.min_log_q);
  lower.insert(lower.end(), {g.min_stay, g.min_gain, g.min_fuzzifier, g.min_separation});
  upper.insert(upper.end(), {g.max_stay, g.max_gain, g.max_fuzzifier, g.max_separation});
  auto make = [&](const std::vector<double>& x, int window) {
    FcmImmSpec spec = base;
    const std::size_t m = static_cast<std::size_t>(n);
    spec.process_noise = noise_levels(x, n, g.max_log_q);
    spec.transition = FcmImmSpec::switching_transition(n, x[m]);
    spec.compensation_gain = x[m + 1];
    spec.clustering.fuzzifier = x[m + 2];
    spec.separation = x[m + 3];
    spec.window = window;
    return spec;
  };
  std::vector<double> x0 = {std::log10(std::max(1e-300, base.process_noise[0]))};
  for (int j = 1; j < n; ++j) {
    x0.push_back(std::log10(base.process_noise[static_cast<std::size_t>(j)]) -
                 std::log10(base.process_noise[static_cast<std::size_t>(j - 1)]));
  }
  x0.insert(x0.end(),
            {imm.spec.settings.transition_stay,
             std::clamp(config.filter.compensation_gain, g.min_gain, g.max_gain),
             std::clamp(config.filter.clustering.fuzzifier, g.min_fuzzifier, g.max_fuzzifier),
             std::clamp(config.filter.separation, g.min_separation, g.max_separation)});
  for (std::size_t d = 0; d < x0.size(); ++d) x0[d] = std::clamp(x0[d], lower[d], upper[d]);

  FcmImmSpec best = base;  // λ = 0: the window does not matter; the first candidate is recorded
  best.window = g.windows.front();
  double best_objective = imm.score.objective;
  for (int window : g.windows) {
    const auto window_start = std::chrono::steady_clock::now();
    const SearchResult search = subplex(
        [&](const std::vector<double>& x) {
          const FcmImmSpec spec = make(x, window);
          return score_filter([&] { return make_fcm_imm_filter(spec); }, training, sigma).objective;
        },
        x0, lower, upper, g.max_evaluations, 1e-3);
    result.evaluations += search.evaluations;
    result.windows.push_back({window, search.value, search.evaluations});
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - window_start).count();
    const FcmImmSpec fitted = make(search.x, window);
    spdlog::info(
        "fcm: window {:3}: J = {:.4f} (lambda {:.3f}, m {:.2f}, kappa {:.2f}, stay {:.3f}, q1 "
        "{:.3g}, q{} {:.3g}; {} evaluations, {:.1f} s)",
        window, search.value, fitted.compensation_gain, fitted.clustering.fuzzifier,
        fitted.separation, fitted.transition(0, 0), fitted.process_noise.front(), n,
        fitted.process_noise.back(), search.evaluations, seconds);
    if (search.value < best_objective) {
      best_objective = search.value;
      best = fitted;
    }
  }
  result.spec = best;
  result.spec.mean_memberships = mean_memberships(best, training);
  result.training = score_filter([&] { return make_fcm_imm_filter(result.spec); }, training, sigma);
  result.validation =
      score_filter([&] { return make_fcm_imm_filter(result.spec); }, validation, sigma);
  const Tuned<AxisCvImmSpec> kf = tune_kf(config, training);
  result.evaluations += kf.evaluations;
  result.kf_validation =
      score_filter([&] { return make_axis_cv_imm_filter(kf.spec); }, validation, sigma);
  result.gate_passed =
      result.validation.objective <= config.max_validation_ratio * result.kf_validation.objective;
  result.digest = datasets::digest(training.data);
  result.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  nlohmann::json metrics;
  metrics["model_kind"] = io::kFcmImmKind;
  metrics["model"] = out.string();
  metrics["config"] = config.name;
  metrics["seed"] = config.seed;
  auto score_json = [](const TrackingScore& s) {
    return nlohmann::json{
        {"objective", s.objective}, {"pos_rmse", s.position_rmse}, {"vel_rmse", s.velocity_rmse}};
  };
  metrics["training"] = score_json(result.training);
  metrics["validation"] = score_json(result.validation);
  metrics["imm_lambda0_training"] = score_json(result.imm_training);
  metrics["imm_lambda0_validation"] = score_json(result.imm_validation);
  metrics["kf_validation"] = score_json(result.kf_validation);
  const FcmImmSpec& s = result.spec;
  metrics["parameters"] = {{"process_noise", s.process_noise},
                           {"stay", s.transition(0, 0)},
                           {"compensation_gain", s.compensation_gain},
                           {"fuzzifier", s.clustering.fuzzifier},
                           {"separation", s.separation},
                           {"window", s.window},
                           {"membership_scale", std::string(to_string(s.scale))},
                           {"compensate_lowest", s.compensate_lowest}};
  std::vector<std::vector<double>> rows;
  rows.reserve(static_cast<std::size_t>(s.mode_count()));
  for (int j = 0; j < s.mode_count(); ++j) {
    rows.push_back({s.mean_memberships(j, 0), s.mean_memberships(j, 1), s.mean_memberships(j, 2)});
  }
  metrics["mean_memberships"] = rows;
  nlohmann::json windows = nlohmann::json::array();
  for (const WindowFit& w : result.windows) {
    windows.push_back(
        {{"window", w.window}, {"objective", w.objective}, {"evaluations", w.evaluations}});
  }
  metrics["windows"] = windows;
  metrics["evaluations"] = result.evaluations;
  metrics["training_trajectories"] = config.training.trajectories;
  metrics["validation_trajectories"] = config.training.validation;
  metrics["threads"] = omp_get_max_threads();
  metrics["wall_seconds"] = result.wall_seconds;
  metrics["gate"] = {{"max_validation_ratio", config.max_validation_ratio},
                     {"passed", result.gate_passed}};
  ensure_parent_folder(out);
  write_json_atomically(metrics_path(out), metrics);
  if (!result.gate_passed) return result;

  io::Provenance provenance =
      make_provenance(std::string(io::kFcmImmKind), config.text,
                      static_cast<std::int64_t>(config.seed), result.digest);
  provenance.training_metrics["objective"] = result.training.objective;
  provenance.training_metrics["pos_rmse"] = result.training.position_rmse;
  provenance.training_metrics["vel_rmse"] = result.training.velocity_rmse;
  provenance.validation_metrics["objective"] = result.validation.objective;
  provenance.validation_metrics["pos_rmse"] = result.validation.position_rmse;
  provenance.validation_metrics["vel_rmse"] = result.validation.velocity_rmse;
  provenance.validation_metrics["kf_objective"] = result.kf_validation.objective;
  io::ModelFileWriter writer(out, provenance);
  io::write_fcm_imm(writer, result.spec);
  writer.commit();
  return result;
}

}  // namespace imm::trainer::fcm
