// SPDX-License-Identifier: Apache-2.0
// The FCM acceleration-compensating IMM (seed 003; its clustering in fuzzy_c_means_test.cpp): the
// compensated update against the plain KF and the α–β closed form, the degeneracy of the seed's
// scale-free memberships, and the model file.

#include "imm/filters/fcm_imm.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/random.hpp"
#include "imm/estimation/kalman_mode.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "imm/models/measurement/position_measurement.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "testing/model_files.hpp"
#include "testing/temp_dir.hpp"

namespace imm {
namespace {

TEST(UpdateWithGain, KalmanGainGivesTheKalmanUpdate) {
  GaussianState<2> a;
  a.mean << 3.0, -1.0;
  a.covariance << 40.0, 12.0, 12.0, 9.0;
  GaussianState<2> b = a;
  Matrix<1, 2> H;
  H << 1.0, 0.0;
  const SquareMatrix<1> R = SquareMatrix<1>::Constant(25.0);
  const Vector<1> nu(7.0);
  const auto kalman = update_with_innovation(a, nu, H, R);
  const Matrix<2, 1> K = b.covariance.col(0) / (b.covariance(0, 0) + 25.0);
  const auto given = update_with_gain(b, nu, H, R, K);
  ASSERT_TRUE(kalman.ok() && given.ok());
  EXPECT_NEAR((a.mean - b.mean).norm(), 0.0, 1e-12);
  EXPECT_NEAR((a.covariance - b.covariance).norm(), 0.0, 1e-12);
  EXPECT_NEAR(kalman.log_likelihood, given.log_likelihood, 1e-12);
}

TEST(UpdateWithGain, AnyGainGivesItsExactErrorCovariance) {
  // Scalar state, P⁻ = 4, R = 1, K = 0.5 (the Kalman gain is 0.8): the error x − x̂⁺ =
  // (1 − K)(x − x̂⁻) − K v has variance (1 − K)² P⁻ + K² R = 1 + 0.25 = 1.25.
  GaussianState<1> state;
  state.mean << 0.0;
  state.covariance << 4.0;
  Matrix<1, 1> H = Matrix<1, 1>::Ones();
  const auto report = update_with_gain(state, Vector<1>(2.0), H,
                                       SquareMatrix<1>(SquareMatrix<1>::Ones()), Matrix<1, 1>(0.5));
  ASSERT_TRUE(report.ok());
  EXPECT_DOUBLE_EQ(state.mean(0), 1.0);
  EXPECT_DOUBLE_EQ(state.covariance(0, 0), 1.25);
  EXPECT_NEAR(report.log_likelihood, -0.5 * (4.0 / 5.0 + std::log(5.0) + std::log(2 * M_PI)),
              1e-14);
}

// --- FCM-IMM ------------------------------------------------------------------------------------

GaussianState<2> exact_start(double p, double v, double variance) {
  GaussianState<2> s;
  s.mean << p, v;
  s.covariance = variance * SquareMatrix<2>::Identity();
  return s;
}

TEST(FcmImm, CompensationGainZeroIsThePlainImm) {
  FcmImmSpec spec;
  spec.sample_period = 1.0;
  spec.compensation_gain = 0.0;
  spec.process_noise = {0.5, 40.0, 900.0};
  spec.transition = FcmImmSpec::switching_transition(3, 0.9);
  spec.initial_probabilities = Eigen::Vector3d(0.6, 0.3, 0.1);
  FcmImmAxisFilter fcm(spec);

  // The textbook IMM of plain CV Kalman modes with the same noise levels.
  std::vector<std::unique_ptr<ImmMode<2, 1>>> modes;
  for (double q : spec.process_noise) {
    modes.push_back(std::make_unique<KalmanMode<2, 2, PositionMeasurement<2, 1>>>(
        "q", constant_velocity<1>(1.0, q),
        PositionMeasurement<2, 1>({0}, SquareMatrix<1>::Constant(1e4)), StateEmbedding<2, 2>()));
  }
  ImmEstimator<2, 1> plain(std::move(modes), spec.transition, spec.initial_probabilities);

  const GaussianState<2> start = exact_start(0.0, 300.0, 1e4);
  fcm.initialize(start);
  plain.initialize(start);
  datasets::Rng rng(3);
  double p = 0.0, v = 300.0;
  for (int k = 1; k <= 200; ++k) {
    const double a = (k > 80 && k < 120) ? 40.0 : 0.0;
    p += v + 0.5 * a;
    v += a;
    const double z = p + rng.normal(0.0, 100.0);
    ASSERT_EQ(fcm.step(z), StepStatus::kOk);
    ASSERT_EQ(plain.step(Vector<1>(z)), StepStatus::kOk);
    EXPECT_NEAR((fcm.estimate().mean - plain.estimate().mean).norm(), 0.0,
                1e-9 * (1.0 + plain.estimate().mean.norm()));
    EXPECT_NEAR((fcm.estimate().covariance - plain.estimate().covariance).norm(), 0.0,
                1e-9 * plain.estimate().covariance.norm());
    EXPECT_NEAR((fcm.mode_probabilities() - plain.mode_probabilities()).norm(), 0.0, 1e-12);
  }
}

TEST(FcmImm, NoiseFreeConstantVelocityIsNotCompensated) {
  for (auto scale : {MembershipScale::kInnovation, MembershipScale::kSeed}) {
    FcmImmSpec spec;
    spec.sample_period = 1.0;
    spec.scale = scale;
    FcmImmAxisFilter filter(spec);
    filter.initialize(exact_start(1000.0, -450.0, 1e4));
    for (int k = 1; k <= 100; ++k) {
      ASSERT_EQ(filter.step(1000.0 - 450.0 * k), StepStatus::kOk);
      EXPECT_NEAR(filter.estimate().mean(0), 1000.0 - 450.0 * k, 1e-9);
      EXPECT_NEAR(filter.estimate().mean(1), -450.0, 1e-9);
      if (scale == MembershipScale::kInnovation) {
        // e = 0 lies on the pinned noise center: nothing is labelled manoeuvre.
        EXPECT_EQ(filter.maneuver_fraction(), 0.0);
        EXPECT_EQ(filter.compensation(), 0.0);
      }
    }
  }
}

// Velocity error of `spec`'s per-axis filter on a target at rest measured with σ = 1 (T = 1):
// RMS over runs at every step 1 … steps, and the mean manoeuvre fraction.
struct NoiseRun {
  std::vector<double> velocity_ms;  // E ṽ²(k)
  double maneuver_fraction = 0.0;
};

NoiseRun on_pure_noise(const FcmImmSpec& spec, int runs, int steps, std::uint64_t seed) {
  NoiseRun out;
  out.velocity_ms.assign(static_cast<std::size_t>(steps), 0.0);
  long samples = 0;
  for (int r = 0; r < runs; ++r) {
    datasets::Rng rng(datasets::derive_seed(seed, static_cast<std::uint64_t>(r)));
    FcmImmAxisFilter filter(spec);
    GaussianState<2> start;
    start.mean.setZero();
    start.covariance << 1.0, 0.0, 0.0, 1.0;
    filter.initialize(start);
    for (int k = 1; k <= steps; ++k) {
      EXPECT_EQ(filter.step(rng.normal()), StepStatus::kOk);
      const double v = filter.estimate().mean(1);
      out.velocity_ms[static_cast<std::size_t>(k - 1)] += v * v / runs;
      out.maneuver_fraction += filter.maneuver_fraction();
      ++samples;
    }
  }
  out.maneuver_fraction /= static_cast<double>(samples);
  return out;
}

TEST(FcmImm, FullCompensationIsTheMarginallyStableAlphaBetaFilter) {
  // Every error labelled acceleration with λ = 1: K_c = ĝ = [1, 2/T], the α = 1, β = 2 filter.
  // Its exact error covariance follows Σ_k = A Σ_{k−1} Aᵀ + ĝ σ² ĝᵀ with A = (I − ĝ H) F, whose
  // eigenvalues are 0 and −1: E ṽ² grows without bound, by 16 σ²/T² per step.
  FcmImmSpec spec;
  spec.sample_period = 1.0;
  spec.process_noise = {0.0};
  spec.transition = Eigen::MatrixXd::Ones(1, 1);
  spec.initial_probabilities = Eigen::VectorXd::Ones(1);
  spec.measurement_sigma = 1.0;
  spec.compensation_gain = 1.0;
  spec.constant_memberships = true;
  spec.mean_memberships = Eigen::RowVector3d(0.0, 0.0, 1.0);
  const int steps = 60;
  const NoiseRun run = on_pure_noise(spec, 4000, steps, 21);

  SquareMatrix<2> A;
  A << 0.0, 0.0, -2.0, -1.0;  // (I − ĝH) F for T = 1
  const Vector<2> g(1.0, 2.0);
  SquareMatrix<2> sigma = SquareMatrix<2>::Zero();  // the start is exact
  for (int k = 1; k <= steps; ++k) {
    sigma = A * sigma * A.transpose() + g * g.transpose();
    EXPECT_NEAR(run.velocity_ms[static_cast<std::size_t>(k - 1)] / sigma(1, 1), 1.0, 0.08) << k;
  }
  EXPECT_NEAR(sigma(1, 1) - (A * sigma * A.transpose() + g * g.transpose())(1, 1), -16.0, 1e-9);
}

TEST(FcmImm, ScaleFreeMembershipsCompensateNoiseAndInflateTheVelocityError) {
  // The seed's memberships on pure noise: about half of every error is "manoeuvre", and at full
  // strength (λ = 1) the velocity error is far above the plain KF's.
  FcmImmSpec seed;
  seed.sample_period = 1.0;
  seed.process_noise = {0.01};
  seed.transition = Eigen::MatrixXd::Ones(1, 1);
  seed.initial_probabilities = Eigen::VectorXd::Ones(1);
  seed.measurement_sigma = 1.0;
  seed.scale = MembershipScale::kSeed;
  seed.compensation_gain = 1.0;
  FcmImmSpec plain = seed;
  plain.compensation_gain = 0.0;
  FcmImmSpec scaled = seed;
  scaled.scale = MembershipScale::kInnovation;
  scaled.separation = 4.0;

  const int runs = 300, steps = 200;
  const NoiseRun a = on_pure_noise(seed, runs, steps, 7);
  const NoiseRun b = on_pure_noise(plain, runs, steps, 7);
  const NoiseRun c = on_pure_noise(scaled, runs, steps, 7);
  auto settled_rms = [&](const NoiseRun& run) {
    double sum = 0.0;
    for (int k = 100; k < steps; ++k) sum += run.velocity_ms[static_cast<std::size_t>(k)];
    return std::sqrt(sum / (steps - 100));
  };
  EXPECT_GT(a.maneuver_fraction, 0.35);
  EXPECT_LT(a.maneuver_fraction, 0.75);
  EXPECT_GT(settled_rms(a), 5.0 * settled_rms(b));
  // The scale-aware memberships leave noise alone.
  EXPECT_LT(c.maneuver_fraction, 0.25);
  EXPECT_LT(settled_rms(c), 0.5 * settled_rms(a));
}

TEST(FcmImm, TracksAConstantAccelerationTargetWithBoundedError) {
  FcmImmSpec spec;  // σ_z = 100 m, q = 1, 100, 2500 (m/s²)²
  spec.sample_period = 1.0;
  for (auto scale : {MembershipScale::kInnovation, MembershipScale::kSeed}) {
    spec.scale = scale;
    spec.compensation_gain = 0.1;
    FcmImmAxisFilter filter(spec);
    filter.initialize(exact_start(0.0, 450.0, 1e4));
    datasets::Rng rng(9);
    double p = 0.0, v = 450.0, worst_p = 0.0, worst_v = 0.0;
    for (int k = 1; k <= 300; ++k) {
      p += v + 0.5 * 30.0;
      v += 30.0;
      ASSERT_EQ(filter.step(p + rng.normal(0.0, 100.0)), StepStatus::kOk);
      if (k > 20) {
        worst_p = std::max(worst_p, std::abs(filter.estimate().mean(0) - p));
        worst_v = std::max(worst_v, std::abs(filter.estimate().mean(1) - v));
      }
    }
    // σ_z = 100 m; the steady-state 1σ errors of the q = 2500 mode are ≈ 70 m and 50 m/s.
    EXPECT_LT(worst_p, 400.0) << to_string(scale);
    EXPECT_LT(worst_v, 300.0) << to_string(scale);
  }
}

TEST(FcmImm, FailedStepLeavesTheFilterUntouched) {
  FcmImmSpec spec;
  spec.sample_period = 1.0;
  FcmImmAxisFilter filter(spec);
  filter.initialize(exact_start(0.0, 10.0, 100.0));
  for (int k = 1; k <= 20; ++k) ASSERT_EQ(filter.step(10.0 * k + std::sin(k)), StepStatus::kOk);
  const GaussianState<2> before = filter.estimate();
  const ModeVector mu = filter.mode_probabilities();
  EXPECT_EQ(filter.step(std::nan("")), StepStatus::kInvalidMeasurement);
  EXPECT_EQ(filter.estimate().mean, before.mean);
  EXPECT_EQ(filter.mode_probabilities(), mu);
  // And the window did not take the bad point: the next step equals that of a twin filter.
  FcmImmAxisFilter twin(spec);
  twin.initialize(exact_start(0.0, 10.0, 100.0));
  for (int k = 1; k <= 20; ++k) ASSERT_EQ(twin.step(10.0 * k + std::sin(k)), StepStatus::kOk);
  ASSERT_EQ(filter.step(215.0), StepStatus::kOk);
  ASSERT_EQ(twin.step(215.0), StepStatus::kOk);
  EXPECT_EQ(filter.estimate().mean, twin.estimate().mean);
}

TEST(FcmImmSpec, ValidationNamesTheField) {
  auto field_of = [](const FcmImmSpec& spec) {
    try {
      spec.validate();
    } catch (const InvalidParameter& error) {
      return error.field();
    }
    return std::string("(valid)");
  };
  FcmImmSpec spec;
  spec.sample_period = 1.0;
  EXPECT_EQ(field_of(spec), "(valid)");
  spec.compensation_gain = 1.5;
  EXPECT_EQ(field_of(spec), "compensation_gain");
  spec = FcmImmSpec{};
  spec.sample_period = 1.0;
  spec.process_noise = {10.0, 1.0, 100.0};
  EXPECT_EQ(field_of(spec), "process_noise[1]");
  spec = FcmImmSpec{};
  spec.sample_period = 1.0;
  spec.window = 2;
  EXPECT_EQ(field_of(spec), "window");
  spec = FcmImmSpec{};
  spec.sample_period = 1.0;
  spec.clustering.fuzzifier = 0.9;
  EXPECT_EQ(field_of(spec), "clustering.fuzzifier");
  spec = FcmImmSpec{};
  spec.sample_period = 1.0;
  spec.constant_memberships = true;
  EXPECT_EQ(field_of(spec), "mean_memberships");
  spec.mean_memberships = Eigen::MatrixXd::Constant(3, 3, 0.5);
  EXPECT_EQ(field_of(spec), "mean_memberships");
  EXPECT_THROW((void)membership_scale_from("fuzzy", "scale"), InvalidParameter);
}

// --- Model file ---------------------------------------------------------------------------------

FcmImmSpec fitted_spec() {
  FcmImmSpec spec;
  spec.sample_period = 1.0;
  spec.process_noise = {0.7, 55.0, 1800.0};
  spec.transition = FcmImmSpec::switching_transition(3, 0.93);
  spec.initial_probabilities = Eigen::Vector3d(0.5, 0.3, 0.2);
  spec.clustering.fuzzifier = 2.4;
  spec.clustering.tolerance = 1e-5;
  spec.clustering.max_iterations = 40;
  spec.window = 24;
  spec.scale = MembershipScale::kInnovation;
  spec.separation = 1.7;
  spec.compensation_gain = 0.62;
  spec.compensate_lowest = false;
  spec.mean_memberships.resize(3, 3);
  spec.mean_memberships << 0.1, 0.8, 0.1, 0.2, 0.6, 0.2, 0.25, 0.5, 0.25;
  return spec;
}

void write(const std::filesystem::path& path, const FcmImmSpec& spec,
           const std::function<void(io::ModelFileWriter&)>& tamper = {}) {
  testing::write_model(path, io::kFcmImmKind, [&](io::ModelFileWriter& writer) {
    io::write_fcm_imm(writer, spec);
    if (tamper) tamper(writer);
  });
}

TEST(FcmImmFile, RoundTrip) {
  const testing::TempDir dir;
  const FcmImmSpec spec = fitted_spec();
  write(dir / "f.h5", spec);
  const FcmImmSpec back = io::read_fcm_imm(dir / "f.h5");
  EXPECT_EQ(back.process_noise, spec.process_noise);
  EXPECT_EQ(back.transition, spec.transition);
  EXPECT_EQ(back.initial_probabilities, spec.initial_probabilities);
  EXPECT_EQ(back.clustering.fuzzifier, 2.4);
  EXPECT_EQ(back.clustering.tolerance, 1e-5);
  EXPECT_EQ(back.clustering.max_iterations, 40);
  EXPECT_EQ(back.window, 24);
  EXPECT_EQ(back.scale, MembershipScale::kInnovation);
  EXPECT_EQ(back.separation, 1.7);
  EXPECT_EQ(back.compensation_gain, 0.62);
  EXPECT_FALSE(back.compensate_lowest);
  EXPECT_EQ(back.mean_memberships, spec.mean_memberships);
  EXPECT_EQ(back.sample_period, spec.sample_period);
  EXPECT_EQ(back.measurement_sigma, spec.measurement_sigma);

  // The filters built from both specs agree step for step.
  FcmImmAxisFilter a(spec), b(back);
  a.initialize(exact_start(0.0, 100.0, 1e4));
  b.initialize(exact_start(0.0, 100.0, 1e4));
  for (int k = 1; k <= 50; ++k) {
    const double z = 100.0 * k + 80.0 * std::sin(0.7 * k);
    ASSERT_EQ(a.step(z), StepStatus::kOk);
    ASSERT_EQ(b.step(z), StepStatus::kOk);
    EXPECT_EQ(a.estimate().mean, b.estimate().mean);
  }
}

TEST(FcmImmFile, HostileValuesAreRefusedByName) {
  const testing::TempDir dir;
  auto refused = [&](const std::string& name, const std::function<void(io::ModelFileWriter&)>& f,
                     const std::string& field) {
    write(dir / (name + ".h5"), fitted_spec(), f);
    try {
      (void)io::read_fcm_imm(dir / (name + ".h5"));
      ADD_FAILURE() << name << ": accepted";
    } catch (const io::FileError& error) {
      EXPECT_NE(std::string(error.what()).find(field), std::string::npos)
          << name << ": " << error.what();
    }
  };
  refused(
      "gain", [](auto& w) { w.set_quantity("/fcm_imm", "compensation_gain", 1.5, "1"); },
      "/fcm_imm@compensation_gain");
  refused(
      "scale", [](auto& w) { w.set_attribute("/fcm_imm", "membership_scale", "fuzzy"); },
      "/fcm_imm@membership_scale");
  refused(
      "window", [](auto& w) { w.set_attribute("/fcm_imm", "window", std::int64_t{1000}); },
      "/fcm_imm@window");
  refused(
      "fuzzifier", [](auto& w) { w.set_quantity("/fcm_imm", "fuzzifier", 1.0, "1"); },
      "/fcm_imm@clustering.fuzzifier");
  refused(
      "separation", [](auto& w) { w.set_quantity("/fcm_imm", "separation", -1.0, "1"); },
      "/fcm_imm@separation");
  refused(
      "order",
      [](auto& w) {
        w.write_vector("/fcm_imm/process_noise", Eigen::Vector3d(5.0, 1.0, 9.0), "m^2/s^4");
      },
      "/fcm_imm/process_noise[1]");
  refused(
      "memberships",
      [](auto& w) {
        w.write_matrix("/fcm_imm/mean_memberships", Eigen::MatrixXd::Ones(3, 2), {"a", "b"}, "1");
      },
      "/fcm_imm/mean_memberships");
  refused(
      "rows",
      [](auto& w) {
        w.write_matrix("/fcm_imm/mean_memberships", Eigen::MatrixXd::Constant(3, 3, 0.5),
                       {"deceleration", "noise", "acceleration"}, "1");
      },
      "/fcm_imm/mean_memberships");
}

}  // namespace
}  // namespace imm
