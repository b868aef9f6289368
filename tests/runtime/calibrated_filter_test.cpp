// SPDX-License-Identifier: Apache-2.0
// The covariance calibration (CalibratedFilter): the identity changes nothing to the bit; factors
// set by hand scale S, the gate's distance and P exactly as stated, from the plots used since the
// start and the NIS level computed by hand; the likelihoods and the estimate stay the model's; an
// invalid calibration is refused naming its field.
#include "imm/tracking/calibrated_filter.hpp"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <memory>
#include <random>

#include "imm/core/invalid_parameter.hpp"
#include "imm/load.hpp"

namespace imm {
namespace {

constexpr const char* kModel = "models/classical_imm_agile_air.h5";

std::unique_ptr<TrackFilter> model_filter() { return load_filter(kModel).filter; }

// A straight target with 30 m plots, started at the origin.
struct Scene {
  std::mt19937_64 rng{5};
  std::normal_distribution<double> unit{0.0, 1.0};
  Eigen::Vector2d plot(int k) {
    return Eigen::Vector2d(200.0 * k, 50.0 * k) + 30.0 * Eigen::Vector2d(unit(rng), unit(rng));
  }
};

void start(TrackFilter& filter) {
  const int n = filter.state_dimension();
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(n);
  Eigen::MatrixXd covariance = Eigen::MatrixXd::Identity(n, n) * 900.0;
  covariance(1, 1) = covariance(n / 2 + 1, n / 2 + 1) = 1e5;
  filter.initialize(mean, covariance);
}

double raw_nis(const TrackFilter& filter) {
  Eigen::Vector2d nu;
  Eigen::Matrix2d S;
  EXPECT_TRUE(filter.innovation(nu, S));
  return nu.dot(S.llt().solve(nu));
}

TEST(CalibratedFilter, TheIdentityChangesNothing) {
  auto raw = model_filter();
  CalibratedFilter calibrated(model_filter(), std::make_shared<CovarianceCalibration>());
  start(*raw);
  start(calibrated);
  Scene scene;
  const int n = raw->state_dimension();
  for (int k = 1; k <= 30; ++k) {
    const Eigen::Vector2d z = scene.plot(k);
    ASSERT_EQ(raw->predict(), StepStatus::kOk);
    ASSERT_EQ(calibrated.predict(), StepStatus::kOk);
    EXPECT_EQ(calibrated.candidate_distance(z), raw->candidate_distance(z));
    EXPECT_EQ(calibrated.candidate_log_likelihood(z), raw->candidate_log_likelihood(z));
    ASSERT_EQ(raw->update(z), StepStatus::kOk);
    ASSERT_EQ(calibrated.update(z), StepStatus::kOk);
    Eigen::MatrixXd a(n, n), b(n, n);
    raw->covariance(a);
    calibrated.covariance(b);
    EXPECT_EQ(a, b);
  }
}

TEST(CalibratedFilter, ScalesByThePlotsUsedAndTheLevelComputedByHand) {
  auto table = std::make_shared<CovarianceCalibration>();
  table->memory = 0.5;
  table->nis_cap = 6.0;
  table->start_innovation = {3.0, 2.0, 1.0};
  table->start_state = {5.0, 4.0, 1.0};
  table->edges = {1.5, 3.0};
  table->level_innovation = {0.5, 1.0, 2.0};
  table->level_state = {0.25, 1.0, 8.0};
  auto reference = model_filter();  // the model without calibration, fed the same plots
  CalibratedFilter calibrated(model_filter(), table);
  start(*reference);
  start(calibrated);
  const int n = reference->state_dimension();
  const auto level_factor = [&](const std::vector<double>& factors, double level) {
    return level < 1.5 ? factors[0] : (level < 3.0 ? factors[1] : factors[2]);
  };
  double level = 2.0;  // the level a track starts with
  Scene scene;
  for (int k = 1; k <= 25; ++k) {
    const Eigen::Vector2d z =
        scene.plot(k) + (k == 12 ? Eigen::Vector2d(400.0, 0.0) : Eigen::Vector2d::Zero());
    const int used = k - 1;
    const double c_s =
        table->start_innovation[std::min(used, 2)] * level_factor(table->level_innovation, level);
    ASSERT_EQ(reference->predict(), StepStatus::kOk);
    ASSERT_EQ(calibrated.predict(), StepStatus::kOk);
    EXPECT_EQ(calibrated.plots_used(), used);
    EXPECT_DOUBLE_EQ(calibrated.nis_level(), level);
    EXPECT_DOUBLE_EQ(calibrated.innovation_scale(), c_s) << k;
    Eigen::Vector2d z_raw, z_cal;
    Eigen::Matrix2d S_raw, S_cal;
    ASSERT_TRUE(reference->predicted_plot(z_raw, S_raw));
    ASSERT_TRUE(calibrated.predicted_plot(z_cal, S_cal));
    EXPECT_EQ(z_cal, z_raw);
    EXPECT_TRUE(S_cal.isApprox(c_s * S_raw, 1e-15)) << k;
    EXPECT_NEAR(calibrated.candidate_distance(z), reference->candidate_distance(z) / c_s,
                1e-12 * reference->candidate_distance(z));
    // The model's own density is not rescaled.
    EXPECT_EQ(calibrated.candidate_log_likelihood(z), reference->candidate_log_likelihood(z));
    ASSERT_EQ(reference->update(z), StepStatus::kOk);
    ASSERT_EQ(calibrated.update(z), StepStatus::kOk);
    // After the update: the innovation keeps the step's factor; the level and P move on.
    const double nis = raw_nis(*reference);
    Eigen::Vector2d nu;
    Eigen::Matrix2d S;
    ASSERT_TRUE(calibrated.innovation(nu, S));
    Eigen::Vector2d nu_raw;
    ASSERT_TRUE(reference->innovation(nu_raw, S_raw));
    EXPECT_TRUE(S.isApprox(c_s * S_raw, 1e-15));
    level = 0.5 * level + 0.5 * std::min(nis, 6.0);
    const double c_p =
        table->start_state[std::min(used + 1, 2)] * level_factor(table->level_state, level);
    Eigen::MatrixXd P_raw(n, n), P(n, n);
    reference->covariance(P_raw);
    calibrated.covariance(P);
    EXPECT_TRUE(P.isApprox(c_p * P_raw, 1e-15)) << k;
    Eigen::VectorXd mean(n), variance(n), mean_raw(n), variance_raw(n);
    calibrated.state(mean, variance);
    reference->state(mean_raw, variance_raw);
    EXPECT_EQ(mean, mean_raw);
    EXPECT_TRUE(variance.isApprox(c_p * variance_raw, 1e-15));
  }
  // A miss keeps the plots used and the level.
  ASSERT_EQ(calibrated.predict(), StepStatus::kOk);
  ASSERT_EQ(calibrated.miss(), StepStatus::kOk);
  EXPECT_EQ(calibrated.plots_used(), 25);
  EXPECT_DOUBLE_EQ(calibrated.nis_level(), level);
  // A restart starts the features again.
  start(calibrated);
  EXPECT_EQ(calibrated.plots_used(), 0);
  EXPECT_DOUBLE_EQ(calibrated.nis_level(), 2.0);
  EXPECT_DOUBLE_EQ(calibrated.innovation_scale(), 3.0);
}

TEST(CalibratedFilter, RefusesAnInvalidCalibrationNamingTheField) {
  const auto field_of = [](const CovarianceCalibration& c) {
    try {
      c.validate();
    } catch (const InvalidParameter& e) {
      return e.field();
    }
    return std::string("valid");
  };
  CovarianceCalibration c;
  EXPECT_EQ(field_of(c), "valid");
  c.memory = 1.0;
  EXPECT_EQ(field_of(c), "calibration.memory");
  c = {};
  c.nis_cap = std::nan("");
  EXPECT_EQ(field_of(c), "calibration.nis_cap");
  c = {};
  c.start_state = {1.0, 2.0};
  EXPECT_EQ(field_of(c), "calibration.start_state");
  c = {};
  c.start_innovation = {-1.0};
  EXPECT_EQ(field_of(c), "calibration.start_innovation[0]");
  c = {};
  c.edges = {2.0, 1.0};
  c.level_innovation = c.level_state = {1.0, 1.0, 1.0};
  EXPECT_EQ(field_of(c), "calibration.edges[1]");
  c.edges = {1.0, 2.0};
  c.level_state = {1.0, 1.0};
  EXPECT_EQ(field_of(c), "calibration.level_state");
  c.level_state = {1.0, INFINITY, 1.0};
  EXPECT_EQ(field_of(c), "calibration.level_state[1]");
  EXPECT_THROW(CalibratedFilter(model_filter(), std::make_shared<CovarianceCalibration>(c)),
               InvalidParameter);
  EXPECT_THROW(CalibratedFilter(nullptr, std::make_shared<CovarianceCalibration>()),
               InvalidParameter);
}

}  // namespace
}  // namespace imm
