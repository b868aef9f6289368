// SPDX-License-Identifier: Apache-2.0
// The classical IMM family with a coordinated-turn mode (CV, CA and CT modes of 4, 6 and 5 states
// in one mixing space), against independent references: a CT EKF on noise-free turns recovers the
// turn rate; the CT mode alone is consistent (NEES inside the χ² bounds) on its own truth model;
// one IMM step over CV + CT and over CV + CA + CT equals the textbook step written out here with
// dynamic matrices; the model file and the config carry the mode through.

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>

#include "imm/filters/plain_imm.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/math/chi_square.hpp"
#include "imm/models/motion/constant_acceleration.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/models/motion/coordinated_turn.hpp"
#include "imm/tracking/tracker.hpp"
#include "testing/model_files.hpp"
#include "testing/specs.hpp"
#include "testing/temp_dir.hpp"

namespace imm {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

constexpr double kTurnPeriod = 2.0;

ModeSpec cv(const std::string& name, double q) {
  return testing::mode_spec(name, MotionKind::kConstantVelocity, q);
}
ModeSpec ca(const std::string& name, double q) {
  return testing::mode_spec(name, MotionKind::kConstantAcceleration, q);
}
ModeSpec ct(const std::string& name, double q, double q_omega) {
  return testing::mode_spec(name, MotionKind::kCoordinatedTurn, q, q_omega);
}

PlainImmSpec turn_spec_of(std::vector<ModeSpec> modes, double sigma) {
  return testing::switching_spec(std::move(modes), kTurnPeriod, 0.05, MeasurementKind::kCartesian,
                                 sigma * sigma * Eigen::Matrix2d::Identity());
}

// A CT EKF alone, started at rest on the turn rate (ω = 0 ± 0.1 rad/s), learns the turn rate of a
// noise-free turn from plots of 1 m noise.
TEST(TurnImm, ACoordinatedTurnEkfRecoversTheTurnRate) {
  for (const double omega : {0.03, -0.08}) {
    SCOPED_TRACE(omega);
    auto imm = build_plain_imm<5>(turn_spec_of({ct("turn", 0.01, 1e-8)}, 1.0));
    Vector<5> truth;
    truth << 0.0, 150.0, 0.0, 20.0, omega;
    GaussianState<5> start;
    start.mean = truth;
    start.mean(4) = 0.0;
    start.covariance = Vector<5>(100.0, 100.0, 100.0, 100.0, 0.01).asDiagonal();
    imm.initialize(start);
    std::mt19937_64 rng(7);
    std::normal_distribution<double> noise(0.0, 1.0);
    for (int k = 0; k < 80; ++k) {
      truth = coordinated_turn_step(truth, kTurnPeriod);
      ASSERT_EQ(imm.step(Vector<2>(truth(0) + noise(rng), truth(2) + noise(rng))), StepStatus::kOk);
    }
    // Within its own 3σ, and that σ a few percent of the turn rate at most.
    const double sigma_omega = std::sqrt(imm.estimate().covariance(4, 4));
    EXPECT_NEAR(imm.estimate().mean(4), omega, 3.0 * sigma_omega);
    EXPECT_LT(sigma_omega, 0.05 * std::abs(omega));
  }
}

// The CT mode alone on truth drawn from its own model (process noise Q, plots of R): the NEES
// averaged over 200 seeded runs stays inside the two-sided 99 % χ² bounds at every checked scan,
// for Cartesian plots.
TEST(TurnImm, TheTurnModeIsConsistentOnItsOwnTruthModel) {
  const double q = 0.5, q_omega = 1e-6, sigma = 20.0;
  const PlainImmSpec spec = turn_spec_of({ct("turn", q, q_omega)}, sigma);
  const SquareMatrix<5> Q = coordinated_turn_noise(kTurnPeriod, q, q_omega);
  const Eigen::LLT<SquareMatrix<5>> q_root(Q + 1e-18 * SquareMatrix<5>::Identity());
  SquareMatrix<5> P0 = Vector<5>(400.0, 25.0, 400.0, 25.0, 1e-4).asDiagonal();
  const Eigen::LLT<SquareMatrix<5>> p_root(P0);
  constexpr int kRuns = 200, kScans = 40;
  std::vector<double> nees(kScans, 0.0);
  std::mt19937_64 rng(2026);
  std::normal_distribution<double> normal(0.0, 1.0);
  const auto draw = [&](int n) {
    VectorXd v(n);
    for (int i = 0; i < n; ++i) v(i) = normal(rng);
    return v;
  };
  for (int run = 0; run < kRuns; ++run) {
    Vector<5> mean;
    mean << 0.0, 200.0, 0.0, 50.0, 0.02;
    Vector<5> truth = mean + p_root.matrixL() * Vector<5>(draw(5));
    auto imm = build_plain_imm<5>(spec);
    imm.initialize(GaussianState<5>{mean, P0});
    for (int k = 0; k < kScans; ++k) {
      truth = coordinated_turn_step(truth, kTurnPeriod) + q_root.matrixL() * Vector<5>(draw(5));
      const Vector<2> z(truth(0) + sigma * normal(rng), truth(2) + sigma * normal(rng));
      ASSERT_EQ(imm.step(z), StepStatus::kOk);
      const Vector<5> error = truth - imm.estimate().mean;
      nees[static_cast<std::size_t>(k)] +=
          error.dot(imm.estimate().covariance.ldlt().solve(error)) / kRuns;
    }
  }
  const double lower = chi_square_quantile(0.005, 5.0 * kRuns) / kRuns;
  const double upper = chi_square_quantile(0.995, 5.0 * kRuns) / kRuns;
  for (const int k : {0, 5, 10, 20, 39}) {
    EXPECT_GT(nees[static_cast<std::size_t>(k)], lower) << "scan " << k;
    EXPECT_LT(nees[static_cast<std::size_t>(k)], upper) << "scan " << k;
  }
}

// The textbook IMM step (Bar-Shalom §11.6.6) written out with dynamic matrices: modes given by
// their own dimension, the indices of their states in the mixing space, and their predict step.
struct ReferenceMode {
  std::vector<int> indices;                           // mixing-space index of each own state
  std::function<VectorXd(const VectorXd&)> f;         // the mean's prediction
  std::function<MatrixXd(const VectorXd&)> jacobian;  // its Jacobian at the mean
  MatrixXd Q;
};

struct ReferenceStep {
  VectorXd mean;
  MatrixXd covariance;
  VectorXd mu;
};

ReferenceStep reference_step(const std::vector<ReferenceMode>& modes, const MatrixXd& transition,
                             const VectorXd& mu, const std::vector<VectorXd>& means,
                             const std::vector<MatrixXd>& covariances, const Eigen::Vector2d& z,
                             const Eigen::Matrix2d& R, int y_index_of_mixing) {
  const auto n = static_cast<int>(modes.size());
  const auto nx = static_cast<int>(means[0].size());
  const VectorXd c = transition.transpose() * mu;
  std::vector<VectorXd> updated_means;
  std::vector<MatrixXd> updated_covariances;
  VectorXd likelihood(n);
  for (int j = 0; j < n; ++j) {
    VectorXd x0 = VectorXd::Zero(nx);
    for (int i = 0; i < n; ++i) x0 += transition(i, j) * mu(i) / c(j) * means[i];
    MatrixXd P0 = MatrixXd::Zero(nx, nx);
    for (int i = 0; i < n; ++i) {
      const VectorXd d = means[i] - x0;
      P0 += transition(i, j) * mu(i) / c(j) * (covariances[i] + d * d.transpose());
    }
    const auto& m = modes[j];
    const auto own = static_cast<int>(m.indices.size());
    VectorXd x(own);
    MatrixXd P(own, own);
    for (int a = 0; a < own; ++a) {
      x(a) = x0(m.indices[a]);
      for (int b = 0; b < own; ++b) P(a, b) = P0(m.indices[a], m.indices[b]);
    }
    const MatrixXd F = m.jacobian(x);
    x = m.f(x);
    P = F * P * F.transpose() + m.Q;
    // Position entries: x at own index 0; y at the own index that maps to the mixing y.
    MatrixXd H = MatrixXd::Zero(2, own);
    H(0, 0) = 1.0;
    for (int a = 0; a < own; ++a) {
      if (m.indices[a] == y_index_of_mixing) H(1, a) = 1.0;
    }
    const Eigen::Vector2d nu = z - H * x;
    const Eigen::Matrix2d S = H * P * H.transpose() + R;
    const MatrixXd K = P * H.transpose() * S.inverse();
    x += K * nu;
    P = (MatrixXd::Identity(own, own) - K * H) * P;
    likelihood(j) = std::exp(-0.5 * nu.dot(S.inverse() * nu)) /
                    (2.0 * std::numbers::pi * std::sqrt(S.determinant()));
    VectorXd embedded = VectorXd::Zero(nx);
    MatrixXd embedded_P = MatrixXd::Zero(nx, nx);
    for (int a = 0; a < own; ++a) {
      embedded(m.indices[a]) = x(a);
      for (int b = 0; b < own; ++b) embedded_P(m.indices[a], m.indices[b]) = P(a, b);
    }
    updated_means.push_back(embedded);
    updated_covariances.push_back(embedded_P);
  }
  ReferenceStep out;
  out.mu = likelihood.cwiseProduct(c);
  out.mu /= out.mu.sum();
  out.mean = VectorXd::Zero(nx);
  for (int j = 0; j < n; ++j) out.mean += out.mu(j) * updated_means[j];
  out.covariance = MatrixXd::Zero(nx, nx);
  for (int j = 0; j < n; ++j) {
    const VectorXd d = updated_means[j] - out.mean;
    out.covariance += out.mu(j) * (updated_covariances[j] + d * d.transpose());
  }
  return out;
}

ReferenceMode linear_mode(std::vector<int> indices, const MatrixXd& F, const MatrixXd& Q) {
  return {std::move(indices), [F](const VectorXd& x) -> VectorXd { return F * x; },
          [F](const VectorXd&) -> MatrixXd { return F; }, Q};
}

ReferenceMode turn_mode(std::vector<int> indices, double q, double q_omega) {
  return {std::move(indices),
          [](const VectorXd& x) -> VectorXd {
            return coordinated_turn_step(Vector<5>(x), kTurnPeriod);
          },
          [](const VectorXd& x) -> MatrixXd {
            return coordinated_turn_jacobian(Vector<5>(x), kTurnPeriod);
          },
          coordinated_turn_noise(kTurnPeriod, q, q_omega)};
}

// One step of the library's IMM from a state where the modes differ (two steps after a start, so
// that mixing has something to mix), against the written-out step from the same modes' estimates.
template <int NX>
void expect_textbook_step(const PlainImmSpec& spec, const std::vector<ReferenceMode>& reference,
                          int y_index) {
  auto imm = build_plain_imm<NX>(spec);
  GaussianState<NX> start;
  start.mean.setZero();
  start.mean(1) = 100.0;
  start.mean(y_index + 1) = -30.0;
  start.covariance = 50.0 * SquareMatrix<NX>::Identity();
  start.covariance(NX - 1, NX - 1) = 0.01;
  imm.initialize(start);
  ASSERT_EQ(imm.step(Vector<2>(205.0, -58.0)), StepStatus::kOk);
  ASSERT_EQ(imm.step(Vector<2>(398.0, -126.0)), StepStatus::kOk);
  // The modes' current estimates, through the mode interface (what the reference mixes).
  std::vector<VectorXd> means;
  std::vector<MatrixXd> covariances;
  for (int j = 0; j < imm.mode_count(); ++j) {
    Vector<NX> mean;
    SquareMatrix<NX> covariance;
    imm.mode(j).embedded_estimate(mean, covariance);
    means.emplace_back(mean);
    covariances.emplace_back(covariance);
  }
  const VectorXd mu = imm.mode_probabilities();
  const Eigen::Vector2d z(603.0, -170.0);
  const ReferenceStep expected = reference_step(reference, spec.transition, mu, means, covariances,
                                                z, spec.measurement.covariance, y_index);
  ASSERT_EQ(imm.step(z), StepStatus::kOk);
  EXPECT_LT((imm.mode_probabilities() - expected.mu).cwiseAbs().maxCoeff(), 1e-10)
      << imm.mode_probabilities().transpose() << "\n"
      << expected.mu.transpose();
  EXPECT_LT((imm.estimate().mean - expected.mean).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_LT((imm.estimate().covariance - expected.covariance).cwiseAbs().maxCoeff(),
            1e-8 * expected.covariance.cwiseAbs().maxCoeff());
}

TEST(TurnImm, OneStepOverCvAndCtIsTheTextbookStep) {
  const PlainImmSpec spec = turn_spec_of({cv("cv", 0.1), ct("ct", 1.0, 1e-4)}, 10.0);
  const auto cv_model = constant_velocity<2>(kTurnPeriod, 0.1);
  expect_textbook_step<5>(spec,
                          {linear_mode({0, 1, 2, 3}, cv_model.transition, cv_model.process_noise),
                           turn_mode({0, 1, 2, 3, 4}, 1.0, 1e-4)},
                          2);
}

TEST(TurnImm, OneStepOverCvCaAndCtIsTheTextbookStep) {
  const PlainImmSpec spec = turn_spec_of({cv("cv", 0.1), ca("ca", 0.5), ct("ct", 1.0, 1e-4)}, 10.0);
  const auto cv_model = constant_velocity<2>(kTurnPeriod, 0.1);
  const auto ca_model = constant_acceleration<2>(kTurnPeriod, 0.5);
  expect_textbook_step<7>(
      spec,
      {linear_mode({0, 1, 3, 4}, cv_model.transition, cv_model.process_noise),
       linear_mode({0, 1, 2, 3, 4, 5}, ca_model.transition, ca_model.process_noise),
       turn_mode({0, 1, 3, 4, 6}, 1.0, 1e-4)},
      3);
}

// The spec's layout, its refusals, the model file's round trip, and a Tracker's two-point start
// of a state with a turn rate (ω = 0 with the spec's prior variance).
TEST(TurnImm, TheSpecTheFileAndTheTrackerCarryTheTurnMode) {
  PlainImmSpec spec = turn_spec_of({cv("cv", 0.1), ct("ct", 1.0, 1e-4)}, 10.0);
  EXPECT_EQ(spec.mixing_dimension(), 5);
  EXPECT_EQ(turn_spec_of({ca("ca", 1.0), ct("ct", 1.0, 1e-4)}, 1.0).mixing_dimension(), 7);
  EXPECT_EQ(build_plain_imm(spec).index(), 2U);
  PlainImmSpec no_prior = spec;
  no_prior.initialization.turn_rate_variance = 0.0;
  try {
    no_prior.validate();
    FAIL() << "a CT mode without a turn-rate prior was accepted";
  } catch (const InvalidParameter& error) {
    EXPECT_EQ(error.field(), "initialization.turn_rate_variance");
  }
  PlainImmSpec wild = spec;
  wild.modes[1].turn_noise = std::nan("");
  EXPECT_THROW(wild.validate(), InvalidParameter);

  const testing::TempDir dir;
  const auto path = dir / "ct.h5";
  testing::write_model(path, io::kPlainImmKind,
                       [&](io::ModelFileWriter& writer) { io::write_plain_imm(writer, spec); });
  const PlainImmSpec read = io::read_plain_imm(path);
  ASSERT_EQ(read.modes.size(), 2U);
  EXPECT_EQ(read.modes[1].motion, MotionKind::kCoordinatedTurn);
  EXPECT_EQ(read.modes[1].turn_noise, 1e-4);
  EXPECT_EQ(read.initialization.turn_rate_variance, 0.01);

  Tracker tracker(make_plain_imm_filter(spec), spec.track_options());
  ASSERT_EQ(tracker.state_dimension(), 5);
  (void)tracker.process(0, Eigen::Vector2d(0.0, 0.0));
  (void)tracker.process(1, Eigen::Vector2d(200.0, 0.0));
  ASSERT_TRUE(tracker.initialized());
  Eigen::VectorXd mean(5), variance(5);
  tracker.state(mean, variance);
  EXPECT_NEAR(mean(1), 100.0, 1e-9);
  EXPECT_EQ(mean(4), 0.0);
  EXPECT_GT(variance(4), 0.0);
}

}  // namespace
}  // namespace imm
