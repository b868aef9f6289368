// SPDX-License-Identifier: Apache-2.0
// The IMM cycle in two halves (ImmEstimator::predict, candidate_*, update, miss): on every shipped
// plain-IMM model, the same numbers as step() and predict_only() to the bit; candidate queries
// change nothing; the candidate likelihood is the one the update then reports; the gate's
// distance against a hand-computed mixture; a model whose prediction needs the plot scores its
// candidates by trial updates.
#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>
#include <cstring>
#include <random>
#include <stdexcept>
#include <string>
#include <variant>

#include "imm/filters/plain_imm.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/tracking/tracker.hpp"
#include "testing/shipped_models.hpp"
#include "testing/specs.hpp"

namespace imm {
namespace {

template <int NX>
bool same_bits(const GaussianState<NX>& a, const GaussianState<NX>& b) {
  return std::memcmp(a.mean.data(), b.mean.data(), sizeof(double) * NX) == 0 &&
         std::memcmp(a.covariance.data(), b.covariance.data(), sizeof(double) * NX * NX) == 0;
}

// Plots of a target flying a slow turn, in the spec's measurement (Cartesian or polar about the
// origin), with noise of the spec's R.
Vector<2> plot_of(const PlainImmSpec& spec, int k, std::mt19937_64& rng) {
  const double T = spec.sample_period;
  const double t = k * T;
  const double scale = std::sqrt(spec.measurement.covariance(0, 0));
  const double x = 200.0 * scale + 3.0 * scale * std::cos(0.02 * t) * t / T;
  const double y = 100.0 * scale + 3.0 * scale * std::sin(0.02 * t) * t / T;
  const Eigen::LLT<Eigen::Matrix2d> llt(spec.measurement.covariance);
  std::normal_distribution<double> unit(0.0, 1.0);
  const Vector<2> noise = llt.matrixL() * Vector<2>(unit(rng), unit(rng));
  if (spec.measurement.kind == MeasurementKind::kPolar) {
    return Vector<2>(std::hypot(x, y), std::atan2(y, x)) + noise;
  }
  return Vector<2>(x, y) + noise;
}

template <int NX>
void expect_split_equals_step(const PlainImmSpec& spec, const std::string& name) {
  SCOPED_TRACE(name);
  ImmEstimator<NX, 2> whole = build_plain_imm<NX>(spec);
  ImmEstimator<NX, 2> split = build_plain_imm<NX>(spec);
  ASSERT_TRUE(split.predicts_before_the_plot());
  std::mt19937_64 rng(11);
  GaussianState<NX> start;
  start.mean.setZero();
  start.covariance.setIdentity();
  const Vector<2> first = plot_of(spec, 0, rng);
  if (spec.measurement.kind == MeasurementKind::kPolar) {
    start.mean(0) = first(0) * std::cos(first(1));
    start.mean(NX >= 6 ? 3 : 2) = first(0) * std::sin(first(1));
  } else {
    start.mean(0) = first(0);
    start.mean(NX >= 6 ? 3 : 2) = first(1);
  }
  start.covariance *= 100.0 * spec.measurement.covariance(0, 0);
  whole.initialize(start);
  split.initialize(start);
  int updates = 0;
  for (int k = 1; k <= 120; ++k) {
    const Vector<2> z = plot_of(spec, k, rng);
    ASSERT_EQ(split.predict(), StepStatus::kOk) << k;
    const GaussianState<NX> before = split.estimate();
    // Candidates: the plot, one far off, and an unusable one; none changes the track.
    const double likelihood = split.candidate_log_likelihood(z);
    const Vector<2> far = z + Vector<2>(1e3, 1.0) * std::sqrt(spec.measurement.covariance(0, 0));
    EXPECT_LT(split.candidate_log_likelihood(far), likelihood) << k;
    EXPECT_GT(split.candidate_distance(far), split.candidate_distance(z)) << k;
    EXPECT_TRUE(std::isnan(split.candidate_log_likelihood(Vector<2>(std::nan(""), 0.0))));
    Vector<2> z_hat;
    SquareMatrix<2> S;
    ASSERT_TRUE(split.predicted_plot(z_hat, S));
    EXPECT_TRUE(same_bits(split.estimate(), before));
    if (k % 9 == 0) {  // a missed scan, after a refused plot was tried
      EXPECT_EQ(split.update(Vector<2>(std::nan(""), 0.0)), StepStatus::kInvalidMeasurement);
      ASSERT_EQ(whole.predict_only(), StepStatus::kOk);
      ASSERT_EQ(split.miss(), StepStatus::kOk);
    } else {
      ASSERT_EQ(whole.step(z), StepStatus::kOk) << k;
      ASSERT_EQ(split.update(z), StepStatus::kOk) << k;
      ++updates;
      // The candidate's likelihood is the one the update reports (its EKF's first linearization).
      EXPECT_NEAR(likelihood, split.log_predictive_likelihood(),
                  1e-9 * std::max(1.0, std::abs(likelihood)))
          << k;
    }
    ASSERT_TRUE(same_bits(whole.estimate(), split.estimate())) << "scan " << k;
    ASSERT_EQ(whole.log_mode_probabilities(), split.log_mode_probabilities()) << k;
    EXPECT_FALSE(split.predicted());
  }
  EXPECT_GT(updates, 100);
}

void expect_split_equals_step(const PlainImmSpec& spec, const std::string& name) {
  switch (spec.mixing_dimension()) {
    case 4:
      return expect_split_equals_step<4>(spec, name);
    case 5:
      return expect_split_equals_step<5>(spec, name);
    case 6:
      return expect_split_equals_step<6>(spec, name);
    default:
      return expect_split_equals_step<7>(spec, name);
  }
}

TEST(SplitCycle, EqualsStepToTheBitOnEveryShippedPlainImm) {
  int checked = 0;
  for (const auto& path : testing::shipped_models()) {
    if (io::ModelFileReader(path).provenance().model_kind != io::kPlainImmKind) continue;
    const PlainImmSpec spec = io::read_plain_imm(path);
    if (spec.has_noise_schedule()) continue;  // SplitCycle.AScheduleRefuses
    expect_split_equals_step(spec, path.string());
    ++checked;
  }
  EXPECT_GE(checked, 5);  // the CV-mode baselines, the cv3 IMM, the CV/CA/CT IMMs
}

// The gate's distance of a two-mode Cartesian IMM against the mixture written out: ν_j = z − ẑ_j
// from each mode's predicted plot, ν = Σ c_j ν_j, S = Σ c_j (S_j + (ν_j − ν)(ν_j − ν)ᵀ).
TEST(SplitCycle, CandidateDistanceIsTheCollapsedMixturesNis) {
  PlainImmSpec spec = testing::switching_spec(
      {testing::mode_spec("quiet", MotionKind::kConstantVelocity, 0.01),
       testing::mode_spec("turn", MotionKind::kCoordinatedTurn, 4.0, 1e-4)},
      1.0, 0.1, MeasurementKind::kCartesian, Eigen::Matrix2d::Identity() * 25.0);
  ImmEstimator<5, 2> imm = build_plain_imm<5>(spec);
  GaussianState<5> start;
  start.mean << 0.0, 100.0, 0.0, 0.0, 0.02;
  start.covariance = Eigen::Matrix<double, 5, 1>(25.0, 100.0, 25.0, 100.0, 1e-3).asDiagonal();
  imm.initialize(start);
  ASSERT_EQ(imm.step(Vector<2>(101.0, 3.0)), StepStatus::kOk);
  ASSERT_EQ(imm.predict(), StepStatus::kOk);
  const Vector<2> z(204.0, 9.0);
  // c_j = Σ_i p_ij μ_i.
  const ModeVector mu = imm.mode_probabilities();
  const Eigen::Vector2d c = spec.transition.transpose() * mu;
  Vector<2> nu = Vector<2>::Zero();
  std::array<Vector<2>, 2> nus;
  std::array<SquareMatrix<2>, 2> covariances;
  for (int j = 0; j < 2; ++j) {
    Vector<2> z_hat;
    ASSERT_TRUE(imm.predicted_plot(j, z_hat, covariances[static_cast<std::size_t>(j)]));
    nus[static_cast<std::size_t>(j)] = z - z_hat;
    nu += c(j) / c.sum() * nus[static_cast<std::size_t>(j)];
  }
  SquareMatrix<2> S = SquareMatrix<2>::Zero();
  for (int j = 0; j < 2; ++j) {
    const Vector<2> d = nus[static_cast<std::size_t>(j)] - nu;
    S += c(j) / c.sum() * (covariances[static_cast<std::size_t>(j)] + d * d.transpose());
  }
  const double expected = nu.dot(S.inverse() * nu);
  EXPECT_NEAR(imm.candidate_distance(z), expected, 1e-10 * expected);
  Vector<2> z_hat;
  SquareMatrix<2> whole;
  ASSERT_TRUE(imm.predicted_plot(z_hat, whole));
  EXPECT_TRUE(z_hat.isApprox(z - nu, 1e-12));
  EXPECT_TRUE(whole.isApprox(S, 1e-12));
}

// A scheduled mode scales Q by the plot's own innovation, so candidates are trial updates. With
// s ≡ 2 on every mode the scheduled IMM is the unscheduled one at twice every intensity (the
// closed form ScheduledNoise.AConstantScheduleScalesEveryIntensity checks): the trial's
// likelihood (a trial update), its distance and the predicted plot (both of the prediction without
// the plot) must be that IMM's held ones, and update() must be step() to the bit after candidates
// elsewhere were tried.
TEST(SplitCycle, AScheduleScoresCandidatesByTrialUpdates) {
  PlainImmSpec spec = testing::cv3_spec();
  PlainImmSpec doubled = spec;
  for (std::size_t j = 0; j < spec.modes.size(); ++j) {
    spec.modes[j].noise_schedule = FuzzyRuleTable({FuzzyRule{0.0, 1.0, 0.0, 1.0, 2.0}});
    doubled.modes[j].process_noise *= 2.0;
  }
  ImmEstimator<4, 2> split = build_plain_imm<4>(spec), whole = build_plain_imm<4>(spec);
  ImmEstimator<4, 2> reference = build_plain_imm<4>(doubled);
  EXPECT_FALSE(split.predicts_before_the_plot());
  ASSERT_TRUE(reference.predicts_before_the_plot());
  std::mt19937_64 rng(5);
  const GaussianState<4> start{Vector<4>(400.0, 3.0, 200.0, 1.5),
                               Vector<4>(1.0, 0.5, 1.0, 0.5).asDiagonal()};
  split.initialize(start);
  whole.initialize(start);
  reference.initialize(start);
  const Vector<2> elsewhere(1e3, -1e3), unusable(std::nan(""), 0.0);
  for (int k = 1; k < 40; ++k) {
    const Vector<2> z = plot_of(spec, k, rng);
    ASSERT_EQ(split.predict(), StepStatus::kOk);
    ASSERT_EQ(reference.predict(), StepStatus::kOk);
    const GaussianState<4> before = split.estimate();
    EXPECT_TRUE(std::isnan(split.candidate_log_likelihood(unusable)));
    (void)split.candidate_distance(elsewhere);
    const double likelihood = split.candidate_log_likelihood(z);
    const double distance = split.candidate_distance(z);
    Vector<2> z_hat, z_ref;
    SquareMatrix<2> S, S_ref;
    ASSERT_TRUE(split.predicted_plot(z_hat, S));
    EXPECT_TRUE(same_bits(split.estimate(), before)) << "a candidate moved the track";
    // The gate is the predicted plot's (the prediction without the plot).
    const Vector<2> nu = z - z_hat;
    EXPECT_NEAR(distance, nu.dot(S.inverse() * nu), 1e-12 * distance);
    if (k > 1) {  // s of the last step is 2 from the first step on
      ASSERT_TRUE(reference.predicted_plot(z_ref, S_ref));
      EXPECT_TRUE(z_hat.isApprox(z_ref, 1e-12)) << k;
      EXPECT_TRUE(S.isApprox(S_ref, 1e-12)) << k;
      EXPECT_NEAR(likelihood, reference.candidate_log_likelihood(z), 1e-9 * std::abs(likelihood));
      EXPECT_NEAR(distance, reference.candidate_distance(z), 1e-9 * distance);
    }
    if (k % 7 == 3) {  // a missed scan
      ASSERT_EQ(split.miss(), whole.predict_only());
      ASSERT_EQ(reference.miss(), StepStatus::kOk);
    } else {
      ASSERT_EQ(split.update(unusable), StepStatus::kInvalidMeasurement);
      ASSERT_EQ(split.update(z), whole.step(z));
      ASSERT_EQ(reference.update(z), StepStatus::kOk);
      EXPECT_EQ(likelihood, whole.log_predictive_likelihood()) << k;
    }
    ASSERT_TRUE(same_bits(split.estimate(), whole.estimate())) << k;
    ASSERT_EQ(split.log_mode_probabilities(), whole.log_mode_probabilities());
  }
}

}  // namespace
}  // namespace imm
