// SPDX-License-Identifier: Apache-2.0
// Speed of one filter step (Google Benchmark). Not a test: run `make bench` or
//   build/bin/imm-bench --benchmark_min_time=1
//
// BM_PlainImmStep is the reference figure: the 2-D CV IMM of configs/track/cv3_imm.toml
// (three modes, state [x, vx, y, vy]) fed the seed-000 plots.

#include <benchmark/benchmark.h>

#include <memory>
#include <vector>

#include "bench_inputs.hpp"
#include "bench_main.hpp"
#include "imm/estimation/imm_estimator.hpp"
#include "imm/estimation/kalman_mode.hpp"
#include "imm/filters/aimm.hpp"
#include "imm/filters/axis_cv_imm.hpp"
#include "imm/filters/fcm_imm.hpp"
#include "imm/filters/fimm.hpp"
#include "imm/filters/ga_fuzzy_imm.hpp"
#include "imm/filters/mlp_input_estimator.hpp"
#include "imm/filters/plain_imm.hpp"
#include "imm/filters/wimm.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/models/measurement/polar_measurement.hpp"
#include "imm/models/measurement/position_measurement.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/models/motion/singer.hpp"
#include "imm/support/plain_imm_config.hpp"

namespace {

using imm::TrackFilter;
using imm::bench::preset_sample_period;
using imm::bench::preset_track;
using imm::bench::table3_plots;
using imm::bench::w1_input;

imm::GaussianState<4> start_state(const Eigen::MatrixXd& plots) {
  imm::GaussianState<4> state;
  state.mean << plots(0, 0), 0.0, plots(0, 1), 0.0;
  state.covariance = Eigen::Vector4d(0.25, 0.5, 0.25, 0.5).asDiagonal();
  return state;
}

void BM_PlainImmStep(benchmark::State& state) {
  const auto spec =
      imm::support::load_plain_imm_config(IMM_SOURCE_DIR "/configs/track/cv3_imm.toml");
  auto imm = imm::build_plain_imm<4>(spec);
  const Eigen::MatrixXd& plots = table3_plots();
  imm.initialize(start_state(plots));
  Eigen::Index k = 1;
  for (auto _ : state) {
    const imm::Vector<2> z = plots.row(k).transpose();
    benchmark::DoNotOptimize(imm.step(z));
    benchmark::DoNotOptimize(imm.estimate().mean.data());
    if (++k == plots.rows()) {
      k = 1;
      imm.initialize(start_state(plots));
    }
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_PlainImmStep);

void BM_KalmanStepCv2d(benchmark::State& state) {
  const auto motion = imm::constant_velocity<2>(1.0, 1e-4);
  const imm::PositionMeasurement<4, 2> measurement({0, 2}, 0.25 * imm::SquareMatrix<2>::Identity());
  const Eigen::MatrixXd& plots = table3_plots();
  imm::GaussianState<4> filter = start_state(plots);
  Eigen::Index k = 1;
  for (auto _ : state) {
    filter = imm::predict(filter, motion.transition, motion.process_noise);
    const imm::Vector<2> z = plots.row(k).transpose();
    benchmark::DoNotOptimize(imm::update(filter, z, measurement));
    if (++k == plots.rows()) k = 1;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_KalmanStepCv2d);

// CV (4 states, zero-padded) + Singer (6 states) on polar plots: the seed-004 layout.
void BM_CvSingerPolarImmStep(benchmark::State& state) {
  imm::SquareMatrix<2> R;
  R << 50.0 * 50.0, 0.0, 0.0, std::pow(0.5 * 3.141592653589793 / 180.0, 2);
  std::vector<std::unique_ptr<imm::ImmMode<6, 2>>> modes;
  modes.push_back(std::make_unique<imm::KalmanMode<6, 4, imm::PolarMeasurement<4>>>(
      "cv", imm::constant_velocity<2>(2.0, 2.0), imm::PolarMeasurement<4>(0, 2, R),
      imm::StateEmbedding<4, 6>(std::array<int, 4>{0, 1, 3, 4})));
  modes.push_back(std::make_unique<imm::KalmanMode<6, 6, imm::PolarMeasurement<6>>>(
      "singer", imm::singer<2>(2.0, 20.0, 5.0), imm::PolarMeasurement<6>(0, 3, R),
      imm::StateEmbedding<6, 6>()));
  Eigen::Matrix2d pi;
  pi << 0.95, 0.05, 0.05, 0.95;
  imm::ImmEstimator<6, 2> imm(std::move(modes), pi, Eigen::Vector2d(0.5, 0.5));
  imm::GaussianState<6> start;
  start.mean << 99000.0, -100.0, 0.0, 99000.0, -100.0, 0.0;
  start.covariance = Eigen::Matrix<double, 6, 1>(2500, 100, 1, 2500, 100, 1).asDiagonal();
  imm.initialize(start);
  int k = 1;
  for (auto _ : state) {
    const double x = 99000.0 - 200.0 * k, y = 99000.0 - 200.0 * k;
    benchmark::DoNotOptimize(imm.step(imm::Vector<2>(std::hypot(x, y), std::atan2(x, y))));
    if (++k == 250) {
      k = 1;
      imm.initialize(start);
    }
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_CvSingerPolarImmStep);

const Eigen::MatrixXd& zigzag_plots() {
  static const Eigen::MatrixXd plots = preset_track("fcm_imm_zigzag").plots;
  return plots;
}

// One step per iteration of `filter` through `plots` from row 1 on, starting a new track at
// (mean, covariance) after the last row.
void step_through(benchmark::State& state, TrackFilter& filter, const Eigen::MatrixXd& plots,
                  const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) {
  filter.initialize(mean, covariance);
  Eigen::Index k = 1;
  for (auto _ : state) {
    benchmark::DoNotOptimize(filter.step(plots.row(k).transpose()));
    if (++k == plots.rows()) {
      k = 1;
      filter.initialize(mean, covariance);
    }
  }
  state.SetItemsProcessed(state.iterations());
}

// One 2-D step of a per-axis filter pair (x and y), fed the seed-000 plots (σ_z² = 0.25 km²) or
// others with their own measurement variance.
void run_two_axis(benchmark::State& state, TrackFilter& filter,
                  const Eigen::MatrixXd& plots = table3_plots(), double variance = 0.25) {
  step_through(
      state, filter, plots, Eigen::Vector4d(plots(0, 0), 0.0, plots(0, 1), 0.0),
      Eigen::Vector4d(variance, 2 * variance, variance, 2 * variance).asDiagonal().toDenseMatrix());
}

// The GA-fuzzy IMM with the shipped tables (models/ga_fuzzy_imm.h5).
void BM_GaFuzzyImmStep(benchmark::State& state) {
  const auto spec = imm::io::read_ga_fuzzy_imm(IMM_SOURCE_DIR "/models/ga_fuzzy_imm.h5");
  auto filter = imm::make_ga_fuzzy_imm_filter(spec);
  run_two_axis(state, *filter);
}
BENCHMARK(BM_GaFuzzyImmStep);

// The same filter with seed 000's published tables (9, 8 and 8 rules).
void BM_GaFuzzyImmPaperTablesStep(benchmark::State& state) {
  const auto spec =
      imm::io::read_ga_fuzzy_imm(IMM_SOURCE_DIR "/models/reference/ga_fuzzy_imm_paper.h5");
  auto filter = imm::make_ga_fuzzy_imm_filter(spec);
  run_two_axis(state, *filter);
}
BENCHMARK(BM_GaFuzzyImmPaperTablesStep);

// Seed 004's filters on the scenario-1 plots: one step of the normal and of the weighted IMM.
void run_polar(benchmark::State& state, imm::FusionVariant fusion) {
  static const Eigen::MatrixXd plots = preset_track("wimm_table2", 0).plots;
  imm::WimmSpec spec;
  spec.sample_period = preset_sample_period("wimm_table2");
  spec.fusion = fusion;
  imm::WimmFilter filter(spec);
  Eigen::VectorXd mean(6), variance(6);
  mean << 99000.0, -100.0, 0.0, 99000.0, -100.0, 0.0;
  variance << 2500.0, 100.0, 25.0, 2500.0, 100.0, 25.0;
  step_through(state, filter, plots, mean, variance.asDiagonal().toDenseMatrix());
}

void BM_NormalImmPolarStep(benchmark::State& state) { run_polar(state, imm::FusionVariant::kNone); }
BENCHMARK(BM_NormalImmPolarStep);

void BM_WeightedImmStep(benchmark::State& state) { run_polar(state, imm::FusionVariant::kSeed); }
BENCHMARK(BM_WeightedImmStep);

// Seed 001: the shipped network's forward pass, and one step of the input-estimation filter.
void BM_MlpForward(benchmark::State& state) {
  const auto model =
      imm::io::read_mlp_input_estimator(IMM_SOURCE_DIR "/models/mlp_input_estimator.h5");
  Eigen::VectorXd x = Eigen::VectorXd::Zero(2);
  double a = 0.0;
  for (auto _ : state) {
    x(0) = a;
    benchmark::DoNotOptimize(model.network.forward(x));
    a = a > 3.0 ? -3.0 : a + 0.01;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_MlpForward);

void BM_InputEstimationFilterStep(benchmark::State& state) {
  const auto model =
      imm::io::read_mlp_input_estimator(IMM_SOURCE_DIR "/models/mlp_input_estimator.h5");
  imm::MlpInputEstimatorFilter filter(model, model.settings);
  imm::GaussianState<2> start;
  start.mean << 0.0, 100.0;
  start.covariance << 2500.0, 2500.0, 2500.0, 5000.0;
  filter.initialize(start);
  int k = 0;
  for (auto _ : state) {
    ++k;
    benchmark::DoNotOptimize(filter.step(100.0 * k + 30.0 * std::sin(k)));
    if (k == 300) {
      k = 0;
      filter.initialize(start);
    }
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_InputEstimationFilterStep);

void BM_Aimm5Step(benchmark::State& state) {
  imm::AimmSpec spec;
  spec.settings.sample_period = preset_sample_period("ga_imm_table3");  // run_two_axis's plots
  spec.intervals = {0.02, 0.04};
  auto filter = imm::make_aimm_filter(spec);
  run_two_axis(state, *filter);
}
BENCHMARK(BM_Aimm5Step);

// Seed 003's FCM-IMM with the shipped fit (models/fcm_imm.h5), fed the seed-003 plots; the
// clustering of a sliding window per mode and axis dominates.
void BM_FcmImmStep(benchmark::State& state) {
  auto spec = imm::io::read_fcm_imm(IMM_SOURCE_DIR "/models/fcm_imm.h5");
  if (state.range(0) == 1) spec.constant_memberships = true;
  if (state.range(0) == 2) spec.scale = imm::MembershipScale::kSeed;
  auto filter = imm::make_fcm_imm_filter(spec);
  run_two_axis(state, *filter, zigzag_plots(), 1e4);
  state.SetLabel(state.range(0) == 0   ? "fitted"
                 : state.range(0) == 1 ? "constant memberships"
                                       : "seed (scale-free) memberships");
}
BENCHMARK(BM_FcmImmStep)->Arg(0)->Arg(1)->Arg(2);

// The constant-q IMM with the same noise levels, for comparison.
void BM_CvImm3ZigzagStep(benchmark::State& state) {
  const auto fitted = imm::io::read_fcm_imm(IMM_SOURCE_DIR "/models/fcm_imm.h5");
  imm::AxisCvImmSpec spec;
  spec.settings.sample_period = preset_sample_period("fcm_imm_zigzag");
  spec.settings.measurement_sigma = 100.0;
  spec.process_noise = fitted.process_noise;
  auto filter = imm::make_axis_cv_imm_filter(spec);
  run_two_axis(state, *filter, zigzag_plots(), 1e4);
}
BENCHMARK(BM_CvImm3ZigzagStep);

// Seed 002: the shipped TSK sensor model (models/tsk_range_sensor[_hard].h5), h and its 2 × 2
// Jacobian for both outputs, at positions along the cut-in (some outside the trained box).
const char* tsk_model_path(bool hard) {
  return hard ? IMM_SOURCE_DIR "/models/tsk_range_sensor_hard.h5"
              : IMM_SOURCE_DIR "/models/tsk_range_sensor.h5";
}

// The cut-in of seed 002 with R = 0.5² I (the presets' case 1).
imm::datasets::Track cut_in(bool hard) {
  return preset_track(hard ? "fimm_table1_hard" : "fimm_table1", 1);
}

void BM_TskEvaluate(benchmark::State& state) {
  const bool hard = state.range(0) == 1;
  const imm::TskSensorModel model = imm::io::read_tsk_sensor(tsk_model_path(hard));
  const Eigen::MatrixXd truth = cut_in(hard).truth;
  Eigen::Index k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(model.evaluate(Eigen::Vector2d(truth(k, 0), truth(k, 3))));
    k = (k + 1) % truth.rows();
  }
  state.SetLabel(std::string(hard ? "hard" : "default") + " sensor, 3 rules per output, " +
                 std::string(imm::to_string(model.t_norm())));
}
BENCHMARK(BM_TskEvaluate)->Arg(0)->Arg(1);

// One FIMM step on the cut-in plots (R = 0.5² I): range(0) = linearizations per update
// (0: the baseline IMM, h = identity; 1: EKF; 5: IEKF), range(1) = 1 for the hard sensor.
void BM_FimmStep(benchmark::State& state) {
  const int iterations = static_cast<int>(state.range(0));
  const bool hard = state.range(1) == 1;
  const imm::datasets::Track track = cut_in(hard);
  std::shared_ptr<const imm::TskSensorModel> sensor;
  if (iterations > 0) {
    sensor =
        std::make_shared<const imm::TskSensorModel>(imm::io::read_tsk_sensor(tsk_model_path(hard)));
  }
  imm::FimmSpec spec;
  spec.sample_period = preset_sample_period("fimm_table1");
  spec.measurement_covariance = track.noise.covariance();
  spec.iterations = std::max(1, iterations);
  imm::FimmFilter filter(spec, sensor);
  step_through(state, filter, track.plots, track.truth.row(0).transpose(),
               Eigen::MatrixXd::Identity(6, 6));
  state.SetLabel(std::string(iterations == 0   ? "IMM (h = identity)"
                             : iterations == 1 ? "FIMM, EKF"
                                               : "FIMM, IEKF ≤ 5") +
                 (hard ? ", hard sensor" : ""));
}
BENCHMARK(BM_FimmStep)->Args({0, 0})->Args({1, 0})->Args({5, 0})->Args({1, 1})->Args({5, 1});

// --- The reference workloads (tools/workloads)
// ------------------------------------------------------

// W1: one IMM step (predict and update) of the plain IMM built from configs/track/cv3_imm.toml,
// over the workload's 10 000 plots from the W1 start, restarting after the last. Checks the
// filter against the truth column once (position RMSE of the whole run).
// W1's loop over the workload's plots with `before_step(imm, k)` ahead of each step: one loop for
// both W1 benchmarks, so that they differ only in that call.
template <class BeforeStep>
void run_w1_steps(benchmark::State& state, BeforeStep&& before_step) {
  const auto& input = w1_input();
  auto imm = imm::build_plain_imm<4>(imm::workloads::w1_spec());
  imm.initialize(imm::workloads::w1_start());
  Eigen::Index k = 0;
  for (auto _ : state) {
    before_step(imm, k);
    const imm::Vector<2> z = input.plots.row(k).transpose();
    benchmark::DoNotOptimize(imm.step(z));
    benchmark::DoNotOptimize(imm.estimate().mean.data());
    if (++k == input.plots.rows()) {
      k = 0;
      imm.initialize(imm::workloads::w1_start());
    }
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_W1_PlainImmStep(benchmark::State& state) {
  const auto& input = w1_input();
  const auto check = imm::workloads::run_w1(input, static_cast<int>(input.plots.rows()));
  if (!(check.position_rmse < 0.5)) state.SkipWithError("W1: position RMSE above σ_z");
  run_w1_steps(state, [](imm::ImmEstimator<4, 2>& /*imm*/, Eigen::Index /*k*/) {});
  state.counters["rmse_km"] = check.position_rmse;
}
BENCHMARK(BM_W1_PlainImmStep);

// W1's step fed time stamps whose interval changes at every step (0.95 T and 1.05 T in turn): the
// same cycle after every mode's F and Q and the mode transitions are remade for the interval
// (ImmEstimator::set_interval) — the price of irregular time stamps over BM_W1_PlainImmStep.
void BM_W1_PlainImmStepAtChangingIntervals(benchmark::State& state) {
  const double T = imm::workloads::w1_spec().sample_period;
  run_w1_steps(state, [T](imm::ImmEstimator<4, 2>& imm, Eigen::Index k) {
    const double dt = (k % 2 == 0 ? 0.95 : 1.05) * T;
    benchmark::DoNotOptimize(imm.set_interval(dt, dt / T));
  });
}
BENCHMARK(BM_W1_PlainImmStepAtChangingIntervals);

// W3: fuzzy c-means of the 4000 scalars from the given memberships (c = 3, m = 2, 1e-6).
void BM_W3_FuzzyCMeans1d(benchmark::State& state) {
  const auto input = imm::workloads::load_w3_1d(imm::workloads::input_folder());
  std::vector<double> memberships;
  imm::workloads::W3Result result;
  for (auto _ : state) {
    result = imm::workloads::run_w3(input, memberships);
    benchmark::DoNotOptimize(result.centers.data());
  }
  if (std::abs(result.objective - imm::workloads::kW3Objective) > 1e-8) {
    state.SkipWithError("W3: objective differs from the README figure by more than 1e-8");
  }
  state.counters["iterations"] = result.iterations;
  state.counters["objective"] = result.objective;
}
BENCHMARK(BM_W3_FuzzyCMeans1d)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) { return imm::bench::main_with_lane_isa(argc, argv); }
