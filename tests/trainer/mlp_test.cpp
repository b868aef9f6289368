// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "imm/datasets/axis_trajectory.hpp"
#include "imm/datasets/random.hpp"
#include "imm/datasets/track.hpp"
#include "imm/math/lane_isa.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/mlp/mlp_trainer.hpp"
#include "imm/trainer/mlp/network_training.hpp"
#include "imm/trainer/mlp/smoothed_labels.hpp"
#include "mlp/exp_nonpositive.hpp"
#include "testing/config_error.hpp"
#include "testing/temp_dir.hpp"

namespace imm::trainer::mlp {
namespace {

Samples random_samples(int n, std::uint64_t seed) {
  datasets::Rng rng(seed);
  Samples s;
  s.inputs.resize(n, 2);
  s.targets.resize(n);
  for (int i = 0; i < n; ++i) {
    s.inputs(i, 0) = rng.uniform(-2.0, 2.0);
    s.inputs(i, 1) = rng.uniform(-2.0, 2.0);
    s.targets(i) = rng.uniform(0.0, 10.0);
  }
  return s;
}

// ∂E/∂θ by central differences of E = mean ½ (a_L − t/scale)² = MSE / (2 scale²).
TEST(Backpropagation, GradientsMatchFiniteDifferences) {
  for (Activation output : {Activation::kSigmoid, Activation::kLinear}) {
    Network network({2, 10, 10, 1}, output, 12.0, 0.5, 3);
    const Samples samples = random_samples(25, 4);
    std::vector<Eigen::MatrixXd> gw;
    std::vector<Eigen::VectorXd> gb;
    network.gradients(samples, gw, gb);
    auto loss = [&] { return network.mse(samples) / (2.0 * 144.0); };
    const double h = 1e-6;
    for (std::size_t l = 0; l < network.layers().size(); ++l) {
      auto& w = network.layers()[l].weights;
      for (Eigen::Index r = 0; r < w.rows(); ++r) {
        for (Eigen::Index c = 0; c < w.cols(); ++c) {
          const double keep = w(r, c);
          w(r, c) = keep + h;
          const double plus = loss();
          w(r, c) = keep - h;
          const double minus = loss();
          w(r, c) = keep;
          EXPECT_NEAR(gw[l](r, c), (plus - minus) / (2.0 * h), 1e-7) << "layer " << l;
        }
      }
      auto& b = network.layers()[l].bias;
      for (Eigen::Index r = 0; r < b.size(); ++r) {
        const double keep = b(r);
        b(r) = keep + h;
        const double plus = loss();
        b(r) = keep - h;
        const double minus = loss();
        b(r) = keep;
        EXPECT_NEAR(gb[l](r), (plus - minus) / (2.0 * h), 1e-7) << "bias layer " << l;
      }
    }
  }
}

// The 2-10-10-1 network's fused batch gradient is the matrix-product one to rounding, on a batch
// large enough to be split into chunks (and a last block with one sample), and gives the same
// bits on one thread as on two.
TEST(Backpropagation, TheFusedBatchGradientIsTheMatrixProductsOneAtAnyThreadCount) {
  for (const Activation output : {Activation::kLinear, Activation::kSigmoid}) {
    const Network network({2, 10, 10, 1}, output, 12.0, 0.8, 11);
    const Samples samples = random_samples(1033, 5);
    std::vector<Eigen::MatrixXd> fused_w, general_w, one_w;
    std::vector<Eigen::VectorXd> fused_b, general_b, one_b;
    network.gradients(samples, fused_w, fused_b);
    network.gradients_general(samples, general_w, general_b);
    const int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    network.gradients(samples, one_w, one_b);
    omp_set_num_threads(std::max(2, threads));
    std::vector<Eigen::MatrixXd> two_w;
    std::vector<Eigen::VectorXd> two_b;
    network.gradients(samples, two_w, two_b);
    omp_set_num_threads(threads);
    ASSERT_EQ(fused_w.size(), 3U);
    for (std::size_t l = 0; l < 3; ++l) {
      const double scale = general_w[l].cwiseAbs().maxCoeff() + general_b[l].cwiseAbs().maxCoeff();
      EXPECT_LT((fused_w[l] - general_w[l]).cwiseAbs().maxCoeff(), 1e-13 * scale) << "layer " << l;
      EXPECT_LT((fused_b[l] - general_b[l]).cwiseAbs().maxCoeff(), 1e-13 * scale) << "layer " << l;
      EXPECT_EQ(one_w[l], two_w[l]) << "layer " << l;
      EXPECT_EQ(one_b[l], two_b[l]) << "layer " << l;
    }
  }
}

// Where the CPU has AVX-512, the linear output's batch gradient runs a kernel of its own (two
// blocks at a time); it gives the lane kernel's bits, with a last block of one sample and odd
// block counts per chunk. (Elsewhere both runs take the lane kernel.)
TEST(Backpropagation, TheFusedBatchGradientHasTheSameBitsOnEveryInstructionSet) {
  for (const int n : {1033, 7, 17, 520, 1000}) {
    const Network network({2, 10, 10, 1}, Activation::kLinear, 12.0, 0.8, 13);
    const Samples samples = random_samples(n, 6);
    std::vector<Eigen::MatrixXd> wide_w, lane_w;
    std::vector<Eigen::VectorXd> wide_b, lane_b;
    network.gradients(samples, wide_w, wide_b);
    cap_lane_isa(LaneIsa::kAvx2);
    network.gradients(samples, lane_w, lane_b);
    cap_lane_isa(LaneIsa::kAvx512);
    for (std::size_t l = 0; l < 3; ++l) {
      EXPECT_EQ(wide_w[l], lane_w[l]) << "n " << n << ", layer " << l;
      EXPECT_EQ(wide_b[l], lane_b[l]) << "n " << n << ", layer " << l;
    }
  }
}

// The batch gradient's exponential for the sigmoids' non-positive arguments: within 2 ulp of libm's
// over [−708, 0] (a million random arguments and the ends), 0 below, as lane_exp.
TEST(Backpropagation, TheSigmoidsExponentialIsWithinTwoUlpOfLibm) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> wide(-708.0, 0.0), narrow(-1.0, 0.0);
  double worst = 0.0;
  const auto check = [&](double x) {
    const double expected = std::exp(x), got = exp_nonpositive(x);
    const double ulp = std::nextafter(expected, 2.0 * expected + 1.0) - expected;
    worst = std::max(worst, std::abs(got - expected) / ulp);
  };
  for (int i = 0; i < 500000; ++i) {
    check(wide(rng));
    check(narrow(rng));
  }
  for (const double x : {0.0, -0.0, -1e-300, -0.5 * std::log(2.0), -708.0, -707.9999}) check(x);
  EXPECT_LE(worst, 2.0);
  EXPECT_EQ(exp_nonpositive(-709.0), 0.0);
  EXPECT_EQ(exp_nonpositive(-1e6), 0.0);
  EXPECT_EQ(exp_nonpositive(0.0), 1.0);
}

// XOR-like: target 1 where the inputs' signs differ. A 2-10-10-1 sigmoid net fits it.
// The 2-10-10-1 network's compiled path and the general one give the same weights to the bit
// after 3000 one-sample steps (random samples, targets and rates; a linear and a sigmoid output),
// and a network of another shape is unaffected by the fixed path.
TEST(Backpropagation, TheInputEstimatorsFixedShapeStepIsTheGeneralStepToTheBit) {
  for (const Activation output : {Activation::kLinear, Activation::kSigmoid}) {
    Network fixed({2, 10, 10, 1}, output, 12.0, 0.5, 7);
    Network general = fixed;
    datasets::Rng rng(29);
    for (int step = 0; step < 3000; ++step) {
      const double input[2] = {rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0)};
      const double target = rng.uniform(-12.0, 12.0);
      const double hidden = rng.uniform(0.01, 0.3), rate = rng.uniform(0.01, 0.3);
      fixed.update_on_sample(input, target, hidden, rate);
      general.update_general(input, target, hidden, rate);
    }
    for (std::size_t l = 0; l < 3; ++l) {
      ASSERT_EQ(fixed.layers()[l].weights, general.layers()[l].weights) << "layer " << l;
      ASSERT_EQ(fixed.layers()[l].bias, general.layers()[l].bias) << "layer " << l;
    }
    EXPECT_NE(fixed.layers()[0].weights,
              Network({2, 10, 10, 1}, output, 12.0, 0.5, 7).layers()[0].weights);
  }
  Network other({2, 8, 10, 1}, Activation::kLinear, 1.0, 0.5, 3);
  Network copy = other;
  const double input[2] = {0.3, -0.7};
  other.update_on_sample(input, 0.4, 0.1, 0.1);
  copy.update_general(input, 0.4, 0.1, 0.1);
  EXPECT_EQ(other.layers()[1].weights, copy.layers()[1].weights);
}

TEST(Backpropagation, LearnsXorLikeTarget) {
  Samples samples;
  samples.inputs.resize(4, 2);
  samples.inputs << -1, -1, -1, 1, 1, -1, 1, 1;
  samples.targets = Eigen::Vector4d(0.1, 0.9, 0.9, 0.1);
  Network network({2, 10, 10, 1}, Activation::kSigmoid, 1.0, 0.5, 11);
  TrainingOptions options;
  options.phases = {{4000, 0.5, 0.5}};
  const auto curve = train(network, samples, samples, options);
  EXPECT_LT(curve.back().training, 1e-3);
  for (int i = 0; i < 4; ++i) {
    const double x[2] = {samples.inputs(i, 0), samples.inputs(i, 1)};
    EXPECT_NEAR(network.predict(x), samples.targets(i), 0.05);
  }
}

// A smooth target, y = 5 + 3 sin(x₁) x₂ on [−2, 2]², to a known loss, per-sample and batch Adam.
TEST(Backpropagation, LearnsASmoothTarget) {
  Samples samples = random_samples(400, 8);
  for (Eigen::Index i = 0; i < samples.inputs.rows(); ++i) {
    samples.targets(i) = 5.0 + 1.5 * std::sin(samples.inputs(i, 0)) * samples.inputs(i, 1);
  }
  for (UpdateMode mode : {UpdateMode::kPerSample, UpdateMode::kBatch}) {
    Network network({2, 10, 10, 1}, Activation::kSigmoid, 12.0, 0.5, 5);
    TrainingOptions options;
    options.mode = mode;
    options.optimizer = mode == UpdateMode::kBatch ? Optimizer::kAdam : Optimizer::kGradientDescent;
    options.phases = {{mode == UpdateMode::kBatch ? 3000 : 600,
                       mode == UpdateMode::kBatch ? 0.01 : 0.1,
                       mode == UpdateMode::kBatch ? 0.01 : 0.1}};
    const double before = network.mse(samples);
    const auto curve = train(network, samples, samples, options);
    EXPECT_LT(curve.back().training, 0.05)
        << "mode " << static_cast<int>(mode) << ", from " << before;
  }
}

// Full-batch training works on whole-batch matrix products; with OpenMP in the build Eigen would
// split large products across threads (in blocks that depend on the thread count, and in the
// sanitizer build not even reproducibly). Eigen's own threading is off: the trainer parallelizes
// at the level of its jobs, and a model is the same bits at any thread count.
TEST(Backpropagation, FullBatchTrainingDoesNotDependOnTheThreadCount) {
  const Samples samples = random_samples(2000, 12);
  TrainingOptions options;
  options.mode = UpdateMode::kBatch;
  options.phases = {{40, 0.2, 0.2}};
  const int threads = omp_get_max_threads();
  std::vector<Network> trained;
  for (int count : {1, std::max(2, threads)}) {
    omp_set_num_threads(count);
    Network network({2, 64, 64, 1}, Activation::kLinear, 1.0, 0.5, 13);
    (void)train(network, samples, samples, options);
    trained.push_back(network);
  }
  omp_set_num_threads(threads);
  for (std::size_t l = 0; l < trained[0].layers().size(); ++l) {
    EXPECT_EQ(trained[0].layers()[l].weights, trained[1].layers()[l].weights) << "layer " << l;
    EXPECT_EQ(trained[0].layers()[l].bias, trained[1].layers()[l].bias) << "layer " << l;
  }
}

TEST(Backpropagation, TrainingIsDeterministicForASeed) {
  const Samples samples = random_samples(50, 2);
  TrainingOptions options;
  options.phases = {{20, 0.1, 0.1}};
  Network a({2, 10, 10, 1}, Activation::kSigmoid, 12.0, 0.5, 9);
  Network b({2, 10, 10, 1}, Activation::kSigmoid, 12.0, 0.5, 9);
  (void)train(a, samples, samples, options);
  (void)train(b, samples, samples, options);
  EXPECT_EQ(a.layers()[1].weights, b.layers()[1].weights);
  // The trainer's forward pass is the runtime's.
  const Mlp mlp = a.to_mlp();
  const double x[2] = {0.3, -1.2};
  EXPECT_DOUBLE_EQ(mlp.forward(Eigen::Vector2d(x[0], x[1])), a.predict(x));
}

// Progress is reported as training goes: each point of the curve reaches on_point when it is
// measured — before the next epochs run (the network then still has the weights it was measured
// with) — and the points are the curve's.
TEST(Backpropagation, EachLossPointIsReportedWhenItIsMeasured) {
  const Samples samples = random_samples(50, 2);
  TrainingOptions options;
  options.phases = {{25, 0.1, 0.1}};
  options.loss_every = 10;
  Network network({2, 10, 10, 1}, Activation::kSigmoid, 12.0, 0.5, 9);
  std::vector<LossPoint> seen;
  std::vector<double> mse_then;
  options.on_point = [&](const LossPoint& p) {
    seen.push_back(p);
    mse_then.push_back(network.mse(samples));
  };
  const auto curve = train(network, samples, samples, options);
  ASSERT_EQ(seen.size(), curve.size());
  ASSERT_EQ(curve.size(), 4u);  // epochs 0, 10, 20 and the last, 25
  for (std::size_t i = 0; i < curve.size(); ++i) {
    EXPECT_EQ(seen[i].epoch, curve[i].epoch);
    EXPECT_EQ(seen[i].training, curve[i].training);
    EXPECT_EQ(mse_then[i], curve[i].training) << "point " << i << " was not reported live";
  }
}

// With one mode the IMM is a CV Kalman filter, and the labels' smoother is the textbook
// Rauch–Tung–Striebel smoother of it, written out here with explicit 2 × 2 matrices; with several
// modes a constant acceleration of 4 m/s² in low noise is found in the window's interior.
TEST(SmoothedLabels, OneModeIsTheTextbookRtsSmootherAndAnAccelerationIsFound) {
  const double T = 0.5, sigma = 2.0, q = 0.3;
  datasets::Rng rng(4);
  datasets::TrackSet set;
  set.sample_period = T;
  set.scans = 60;
  datasets::Track track;
  track.plots.resize(60, 2);
  for (Eigen::Index k = 0; k < 60; ++k) {
    const double t = T * static_cast<double>(k);
    track.plots(k, 0) = 10.0 * t + sigma * rng.normal();
    track.plots(k, 1) = -3.0 * t + (k >= 20 && k < 40 ? 2.0 * (t - 10.0) * (t - 10.0) : 0.0) +
                        (k >= 40 ? 2.0 * 100.0 + 40.0 * (t - 20.0) : 0.0) + sigma * rng.normal();
  }
  set.tracks = {track};
  AxisCvImmSpec one;
  one.settings.sample_period = T;
  one.settings.measurement_sigma = sigma;
  one.process_noise = {q};
  const datasets::TrackSet smoothed = smoothed_truth(set, one);
  ASSERT_TRUE(smoothed.has_truth);
  // The textbook: forward KF from the two-point start at scan 1, then RTS backward.
  const Eigen::VectorXd z = track.plots.col(0);
  const double r = sigma * sigma;
  Eigen::Matrix2d F, Q;
  F << 1.0, T, 0.0, 1.0;
  Q << T * T * T * T / 4.0, T * T * T / 2.0, T * T * T / 2.0, T * T;
  Q *= q;
  std::vector<Eigen::Vector2d> x(60);
  std::vector<Eigen::Matrix2d> P(60);
  x[1] << z(1), (z(1) - z(0)) / T;
  P[1] << r, r / T, r / T, 2.0 * r / (T * T);
  for (int k = 2; k < 60; ++k) {
    const Eigen::Vector2d xp = F * x[k - 1];
    const Eigen::Matrix2d Pp = F * P[k - 1] * F.transpose() + Q;
    const double S = Pp(0, 0) + r;
    const Eigen::Vector2d K = Pp.col(0) / S;
    x[k] = xp + K * (z(k) - xp(0));
    P[k] = Pp - K * K.transpose() * S;
  }
  std::vector<Eigen::Vector2d> xs = x;
  for (int k = 58; k >= 1; --k) {
    const Eigen::Matrix2d Pp = F * P[k] * F.transpose() + Q;
    xs[k] = x[k] + P[k] * F.transpose() * Pp.inverse() * (xs[k + 1] - F * x[k]);
  }
  for (int k = 1; k < 59; ++k) {
    EXPECT_NEAR(smoothed.tracks[0].truth(k, 0), xs[k](0), 1e-9 * (1.0 + std::abs(xs[k](0))));
    EXPECT_NEAR(smoothed.tracks[0].truth(k, 1), xs[k](1), 1e-9 * (1.0 + std::abs(xs[k](1))));
    EXPECT_NEAR(smoothed.tracks[0].truth(k, 2), (xs[k + 1](1) - xs[k](1)) / T, 1e-8);
  }
  // Three modes, quiet to agile: the y axis accelerates at 4 m/s² over scans 20–39.
  AxisCvImmSpec imm = one;
  imm.process_noise = {1e-3, 1.0, 30.0};
  const datasets::TrackSet labelled = smoothed_truth(set, imm);
  double mean = 0.0;
  for (int k = 24; k < 36; ++k) mean += labelled.tracks[0].truth(k, 5) / 12.0;
  EXPECT_NEAR(mean, 4.0, 0.6);
  double quiet = 0.0;
  for (int k = 44; k < 56; ++k) quiet += std::abs(labelled.tracks[0].truth(k, 5)) / 12.0;
  EXPECT_LT(quiet, 0.6);
  // A window with a gap is refused.
  set.tracks[0].plots(30, 1) = std::nan("");
  EXPECT_THROW((void)smoothed_truth(set, imm), std::runtime_error);
}

TEST(MlpConfig, ShippedConfigIsTheSeedsSchedule) {
  const auto config = load_mlp_config("configs/mlp_input_estimator.toml");
  ASSERT_EQ(config.training.phases.size(), 2u);
  EXPECT_EQ(config.training.phases[0].epochs, 3000);
  EXPECT_DOUBLE_EQ(config.training.phases[0].hidden_rate, 0.1);
  EXPECT_DOUBLE_EQ(config.training.phases[1].hidden_rate, 0.05);
  EXPECT_DOUBLE_EQ(config.training.phases[1].output_rate, 0.01);
  EXPECT_EQ(config.hidden, (std::vector<int>{10, 10}));
  EXPECT_DOUBLE_EQ(config.cv_kf.measurement_variance, 2500.0);
  const auto load = [](const auto& path) { return load_mlp_config(path); };
  const std::string regime = "regime = \"configs/regimes/paper/input_estimator_training.toml\"\n";
  EXPECT_EQ(testing::config_error_key(regime + "[network]\noutput = \"tanh\"\n", load),
            "network.output");
  // The seed's filter takes û as exact; the realistic regimes' config adds its error variance.
  EXPECT_EQ(config.input_noise, MlpTrainingConfig::InputNoise::kNone);
  EXPECT_EQ(load_mlp_config("configs/mlp_input_estimator_tuned.toml").input_noise,
            MlpTrainingConfig::InputNoise::kConsistent);
  EXPECT_EQ(testing::config_error_key(regime + "[network]\ninput_noise = \"guess\"\n", load),
            "network.input_noise");
}

// input_noise = "consistent": the trained model's primary KF, run as the runtime runs it, has a
// mean NIS of 1 (its dimension) over the training and validation tracks the trainer saw, where
// without the input's variance it is above 1. A short schedule on ground_vehicle keeps it quick.
TEST(MlpTrainer, AConsistentInputNoiseMakesThePrimaryKfsMeanNisOneOnTheTracksItSaw) {
  MlpTrainingConfig config = load_mlp_config("configs/mlp_input_estimator_tuned.toml",
                                             "configs/regimes/ground_vehicle.toml");
  ASSERT_EQ(config.input_noise, MlpTrainingConfig::InputNoise::kConsistent);
  for (Phase& phase : config.training.phases) phase.epochs = 40;
  const testing::TempDir dir;
  const MlpTrainingResult result = train_mlp(config, dir / "m.h5");
  MlpInputEstimatorModel model = result.model;
  ASSERT_GT(model.input_variance, 0.0);
  const auto mean_nis = [&](const MlpInputEstimatorModel& m) {
    const double T = m.settings.sample_period, R = m.settings.measurement_variance;
    double sum = 0.0;
    int count = 0;
    for (const datasets::Split split : {datasets::Split::kTraining, datasets::Split::kValidation}) {
      const datasets::TrackSet set =
          datasets::draw_split(config.regime, split, config.regime.splits.seed);
      for (const datasets::AxisTrajectory& axis : datasets::axis_trajectories(set)) {
        MlpInputEstimatorFilter filter(m, m.settings);
        filter.initialize(datasets::two_point_start(axis, T, R));
        for (Eigen::Index k = 2; k < axis.measurement.size(); ++k) {
          double nu = 0.0, S = 0.0;
          if (filter.step(axis.measurement(k)) != StepStatus::kOk || !filter.innovation(nu, S)) {
            continue;
          }
          sum += nu * nu / S;
          ++count;
        }
      }
    }
    return sum / count;
  };
  EXPECT_NEAR(mean_nis(model), 1.0, 1e-6);
  model.input_variance = 0.0;
  EXPECT_GT(mean_nis(model), 1.05);
}

}  // namespace
}  // namespace imm::trainer::mlp
