#include "imm/evaluation/fimm_experiment.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <sstream>

#include "imm/datasets/random.hpp"
#include "imm/datasets/range_sensor.hpp"
#include "imm/filters/fimm.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/trainer/tsk/tsk_trainer.hpp"

namespace imm::evaluation {
namespace {

constexpr int kFirstScoredScan = 2;
constexpr double kAccelerationVariance = 4.0;  // (m/s²)², the start's ξ̈, η̈ uncertainty

// One filter over every run of a row; `make` builds a fresh filter per run.
FimmFilterScore score(const std::function<std::unique_ptr<FimmFilter>()>& make,
                      const datasets::CutInData& data, const Eigen::VectorXd& range_slope, double T,
                      double r) {
  FimmFilterScore out;
  const Eigen::Index steps = data.truth.rows();
  Eigen::VectorXd scan_sum = Eigen::VectorXd::Zero(steps), scan_count = scan_sum;
  out.first_run = Eigen::MatrixXd::Constant(steps, 2, std::numeric_limits<double>::quiet_NaN());
  double squared = 0.0, nees = 0.0;
  long samples = 0, outside = 0;
  for (std::size_t run = 0; run < data.measurements.size(); ++run) {
    const Eigen::MatrixXd& z = data.measurements[run];
    std::unique_ptr<FimmFilter> filter = make();
    Eigen::VectorXd mean = Eigen::VectorXd::Zero(6);
    Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(6, 6);
    for (Eigen::Index axis = 0; axis < 2; ++axis) {
      const Eigen::Index p = 3 * axis;
      mean(p) = z(1, axis);
      mean(p + 1) = (z(1, axis) - z(0, axis)) / T;
      covariance.block<3, 3>(p, p) << r, r / T, 0.0, r / T, 2.0 * r / (T * T), 0.0, 0.0, 0.0,
          kAccelerationVariance;
    }
    filter->initialize(mean, covariance);
    for (Eigen::Index k = kFirstScoredScan; k < steps; ++k) {
      if (filter->step(z.row(k).transpose()) != StepStatus::kOk) {
        ++out.failed_steps;
        continue;
      }
      const GaussianState<6>& x = filter->estimate();
      const Eigen::Vector2d error(x.mean(0) - data.truth(k, 0), x.mean(3) - data.truth(k, 3));
      Eigen::Matrix2d P;
      P << x.covariance(0, 0), x.covariance(0, 3), x.covariance(3, 0), x.covariance(3, 3);
      squared += error.squaredNorm();
      scan_sum(k) += error.squaredNorm();
      scan_count(k) += 1.0;
      nees += error.dot(P.inverse() * error);
      outside += filter->outside_sensor_box() ? 1 : 0;
      ++samples;
      if (run == 0) out.first_run.row(k) << x.mean(0), x.mean(3);
    }
  }
  out.mse = squared / static_cast<double>(samples);
  out.scan_mse = Eigen::VectorXd::Constant(steps, std::numeric_limits<double>::quiet_NaN());
  double flat_sum = 0.0, flat_count = 0.0, steep_sum = 0.0, steep_count = 0.0;
  for (Eigen::Index k = kFirstScoredScan; k < steps; ++k) {
    if (scan_count(k) == 0.0) continue;
    out.scan_mse(k) = scan_sum(k) / scan_count(k);
    const bool flat = range_slope(k) < kFlatSlope;
    (flat ? flat_sum : steep_sum) += scan_sum(k);
    (flat ? flat_count : steep_count) += scan_count(k);
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  out.mse_flat = flat_count > 0.0 ? flat_sum / flat_count : nan;
  out.mse_steep = steep_count > 0.0 ? steep_sum / steep_count : nan;
  out.nees = nees / static_cast<double>(samples);
  out.outside_box = static_cast<double>(outside) / static_cast<double>(samples);
  return out;
}

}  // namespace

FimmExperimentResult run_fimm_experiment(const FimmExperimentOptions& options) {
  const trainer::tsk::TskTrainingConfig config = trainer::tsk::load_tsk_config(options.config);
  const auto sensor = std::make_shared<const TskModel>(io::read_tsk_sensor(options.model));
  FimmExperimentResult result;
  result.runs = options.runs;
  result.seed = options.seed;
  result.softness = config.data.distortion.softness;
  std::ostringstream text;
  text << "noise scale " << config.fimm.noise_scale
       << " (√q₁ = " << std::sqrt(config.fimm.process_noise(0))
       << ", √q₂ = " << std::sqrt(config.fimm.process_noise(1)) << " m/s² per step), IEKF "
       << config.iekf_iterations << " iterations";
  result.fimm_settings = text.str();

  for (std::size_t row = 0; row < options.r_sigmas.size(); ++row) {
    const double sigma = options.r_sigmas[row];
    datasets::CutInScenario scenario = config.scenario;
    scenario.measurement_covariance = sigma * sigma * Eigen::Matrix2d::Identity();
    scenario.runs = options.runs;
    scenario.seed = datasets::derive_seed(options.seed, 200 + row);
    const datasets::CutInData data = datasets::simulate_cut_in(scenario);
    if (row == 0) {
      result.truth = data.truth;
      result.steps = static_cast<int>(data.truth.rows());
      // dη_m/dη of the true sensor along the true path (central differences).
      result.range_slope.resize(result.steps);
      for (int k = 0; k < result.steps; ++k) {
        const Eigen::Vector2d p(data.truth(k, 0), data.truth(k, 3));
        const double h = 1e-4 * std::max(1.0, std::abs(p(1)));
        const Eigen::Vector2d up(p(0), p(1) + h), down(p(0), p(1) - h);
        result.range_slope(k) =
            (scenario.distortion.apply(up)(1) - scenario.distortion.apply(down)(1)) / (2.0 * h);
        if (k >= kFirstScoredScan && result.range_slope(k) < kFlatSlope) ++result.flat_scans;
      }
    }
    FimmSpec spec = config.fimm;
    spec.measurement_covariance = scenario.measurement_covariance;
    FimmSpec iterated = spec;
    iterated.iterations = config.iekf_iterations;
    const double T = spec.sample_period, r = sigma * sigma;
    FimmRow out;
    out.r_sigma = sigma;
    out.imm = score([&] { return std::make_unique<FimmFilter>(spec, nullptr); }, data,
                    result.range_slope, T, r);
    out.fimm = score([&] { return std::make_unique<FimmFilter>(spec, sensor); }, data,
                     result.range_slope, T, r);
    out.fimm_iekf = score([&] { return std::make_unique<FimmFilter>(iterated, sensor); }, data,
                          result.range_slope, T, r);
    out.first_measurements = data.measurements.front();
    result.rows.push_back(std::move(out));
  }

  // The fitted sensor against the truth along the road, and a sample of the data.
  const int points = 200;
  result.sensor_curve.resize(points, 5);
  const double lane = config.scenario.lane_offset;
  for (int i = 0; i < points; ++i) {
    const double eta =
        config.data.lower(1) + (config.data.upper(1) - config.data.lower(1)) * i / (points - 1.0);
    const Eigen::Vector2d on_road = config.data.distortion.apply({0.0, eta});
    const Eigen::Vector2d in_lane = config.data.distortion.apply({lane, eta});
    result.sensor_curve.row(i) << eta, on_road(1), sensor->evaluate({0.0, eta}).value(1),
        in_lane(0), sensor->evaluate({lane, eta}).value(0);
  }
  datasets::RangeSensorData data = datasets::simulate_range_sensor(config.data);
  const Eigen::Index shown = std::min<Eigen::Index>(2000, data.positions.rows());
  result.sensor_samples.resize(shown, 2);
  for (Eigen::Index q = 0; q < shown; ++q) {
    result.sensor_samples.row(q) << data.positions(q, 1), data.outputs(q, 1);
  }
  return result;
}

}  // namespace imm::evaluation
