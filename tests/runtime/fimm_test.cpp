// SPDX-License-Identifier: Apache-2.0
// The fuzzy IMM of seed 002 (its TSK sensor model in tsk_fimm_test.cpp): the iterated EKF against
// the EKF (linear h) and against the MAP point (nonlinear h), the FIMM with an identity sensor
// against the plain IMM, refused specs and initial states, and a bad plot.

#include "imm/filters/fimm.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <functional>
#include <initializer_list>
#include <memory>
#include <string>

#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/range_sensor.hpp"
#include "imm/estimation/kalman_filter.hpp"
#include "imm/filters/wimm.hpp"
#include "imm/models/learned/tsk_sensor_model.hpp"
#include "imm/models/measurement/tsk_sensor_measurement.hpp"
#include "testing/regimes.hpp"
#include "testing/tsk_sensors.hpp"

namespace imm {
namespace {

using testing::sensor_like_model;
using testing::tsk_rule;

/// An exact identity sensor: one rule per output, z₁ = ξ, z₂ = η, σ = 0, a box nothing leaves.
std::shared_ptr<const TskSensorModel> identity_sensor() {
  std::array<TskOutput, 2> outputs;
  outputs[0].rules = {tsk_rule(0.0, 1e3, 0.0, 1e3, 0.0, 1.0, 0.0)};
  outputs[1].rules = {tsk_rule(0.0, 1e3, 0.0, 1e3, 0.0, 0.0, 1.0)};
  return std::make_shared<const TskSensorModel>(
      outputs, TNorm::kMin, Eigen::Vector2d::Constant(-1e6), Eigen::Vector2d::Constant(1e6));
}

// --- Iterated EKF ---------------------------------------------------------------------------

/// z = x³ + v (scalar), a measurement whose slope changes fast.
struct CubicMeasurement {
  static constexpr int kDim = 1;
  double r = 0.01;
  [[nodiscard]] Vector<1> predict(const Vector<1>& x) const {
    return Vector<1>(x(0) * x(0) * x(0));
  }
  [[nodiscard]] Matrix<1, 1> jacobian(const Vector<1>& x) const {
    return Matrix<1, 1>(3.0 * x(0) * x(0));
  }
  [[nodiscard]] Vector<1> residual(const Vector<1>& z, const Vector<1>& p) const { return z - p; }
  [[nodiscard]] SquareMatrix<1> covariance() const { return SquareMatrix<1>(r); }
  [[nodiscard]] bool defined_at(const Vector<1>& x) const { return x.allFinite(); }
};

TEST(IteratedEkf, EqualsTheEkfForALinearMeasurement) {
  const auto model = identity_sensor();
  const TskSensorMeasurement<6> h(model, {0, 3}, 0.3 * SquareMatrix<2>::Identity());
  GaussianState<6> prior;
  prior.mean << 1.0, 0.5, 0.0, 30.0, 3.0, 0.0;
  prior.covariance = Vector<6>(4.0, 1.0, 0.5, 9.0, 2.0, 0.5).asDiagonal();
  prior.covariance(0, 1) = prior.covariance(1, 0) = 0.8;
  GaussianState<6> ekf = prior, iekf = prior;
  const Vector<2> z(2.2, 27.5);
  const auto a = update(ekf, z, h);
  const auto b = iterated_update(iekf, z, h, 8);
  ASSERT_TRUE(a.ok());
  ASSERT_TRUE(b.ok());
  EXPECT_NEAR((ekf.mean - iekf.mean).norm(), 0.0, 1e-12);
  EXPECT_NEAR((ekf.covariance - iekf.covariance).norm(), 0.0, 1e-12);
  EXPECT_NEAR(a.log_likelihood, b.log_likelihood, 1e-12);
}

TEST(IteratedEkf, ReachesTheMapPointOfANonlinearMeasurement) {
  // Prior N(1, 0.5), z = 2.9 through x³ with r = 0.01. The MAP point solves
  // g(x) = (x − 1)/0.5 − 3x² (z − x³)/r = 0; Gauss–Newton (the IEKF) converges to it, the single
  // EKF step overshoots (the slope at the prior mean, 3, is too small for where z lies).
  const CubicMeasurement h;
  GaussianState<1> prior;
  prior.mean(0) = 1.0;
  prior.covariance(0, 0) = 0.5;
  const Vector<1> z(2.9);
  auto gradient = [&](double x) {
    return (x - 1.0) / 0.5 - 3.0 * x * x * (z(0) - x * x * x) / h.r;
  };
  // The root by bisection on [1, 2] (g(1) < 0 < g(2)).
  double lo = 1.0, hi = 2.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (gradient(mid) < 0.0 ? lo : hi) = mid;
  }
  const double map = 0.5 * (lo + hi);
  GaussianState<1> ekf = prior, iekf = prior;
  ASSERT_TRUE(update(ekf, z, h).ok());
  ASSERT_TRUE(iterated_update(iekf, z, h, 50, 1e-14).ok());
  EXPECT_NEAR(iekf.mean(0), map, 1e-10);
  EXPECT_GT(std::abs(ekf.mean(0) - map), 0.05);  // the test can tell the two apart
  // Its covariance is the Gauss–Newton posterior at the MAP point: (1/P + H²/r)⁻¹.
  const double H = 3.0 * map * map;
  EXPECT_NEAR(iekf.covariance(0, 0), 1.0 / (1.0 / 0.5 + H * H / h.r), 1e-12);
}

TEST(IteratedEkf, BadMeasurementLeavesTheStateUnchanged) {
  const CubicMeasurement h;
  GaussianState<1> state;
  state.mean(0) = 1.0;
  state.covariance(0, 0) = 0.5;
  const GaussianState<1> before = state;
  EXPECT_EQ(iterated_update(state, Vector<1>(std::nan("")), h, 5).status,
            StepStatus::kInvalidMeasurement);
  EXPECT_EQ(state.mean, before.mean);
  EXPECT_EQ(state.covariance, before.covariance);
}

// --- FIMM -----------------------------------------------------------------------------------

Eigen::VectorXd cut_in_start(const datasets::Track& data) { return data.truth.row(0).transpose(); }
Eigen::MatrixXd start_covariance() { return Vector<6>(1.0, 1.0, 1.0, 4.0, 4.0, 1.0).asDiagonal(); }

TEST(Fimm, WithAnIdentitySensorItIsThePlainImm) {
  const datasets::Track data = testing::test_track(testing::cut_in_regime(0.5), 1, 1);
  for (int iterations : {1, 4}) {
    FimmSpec spec;
    spec.sample_period = 0.1;
    spec.measurement_covariance = 0.25 * Eigen::Matrix2d::Identity();
    spec.iterations = iterations;
    FimmFilter fimm(spec, identity_sensor());
    FimmFilter imm(spec, nullptr);
    fimm.initialize(cut_in_start(data), start_covariance());
    imm.initialize(cut_in_start(data), start_covariance());
    const Eigen::MatrixXd& z = data.plots;
    for (Eigen::Index k = 1; k < z.rows(); ++k) {
      ASSERT_EQ(fimm.step(z.row(k).transpose()), StepStatus::kOk);
      ASSERT_EQ(imm.step(z.row(k).transpose()), StepStatus::kOk);
      const double scale = 1.0 + imm.estimate().mean.norm();
      ASSERT_NEAR((fimm.estimate().mean - imm.estimate().mean).norm(), 0.0, 1e-10 * scale) << k;
      ASSERT_NEAR((fimm.estimate().covariance - imm.estimate().covariance).norm(), 0.0, 1e-9) << k;
      ASSERT_NEAR((fimm.mode_probabilities() - imm.mode_probabilities()).cwiseAbs().maxCoeff(), 0.0,
                  1e-10)
          << k;
    }
    EXPECT_FALSE(fimm.outside_sensor_box());
  }
}

TEST(Fimm, NoiseScaleKeepsTheSeedsRatio) {
  FimmSpec spec;
  spec.sample_period = 0.1;
  EXPECT_DOUBLE_EQ(spec.process_noise(0), std::pow(100.0 * 9.81e-4, 2));
  EXPECT_DOUBLE_EQ(spec.process_noise(1) / spec.process_noise(0), 25.0);
  spec.noise_scale = 1.0;
  EXPECT_DOUBLE_EQ(spec.process_noise(1), std::pow(5.0 * 9.81e-4, 2));
}

TEST(Fimm, InvalidSpecsAreRefusedByName) {
  auto refused = [](const std::function<void(FimmSpec&)>& change, const std::string& field) {
    FimmSpec spec;
    spec.sample_period = 0.1;
    change(spec);
    try {
      spec.validate();
      ADD_FAILURE() << field << ": accepted";
    } catch (const InvalidParameter& error) {
      EXPECT_EQ(error.field(), field) << error.what();
    }
  };
  refused([](FimmSpec& s) { s.noise_scale = 0.0; }, "noise_scale");
  refused([](FimmSpec& s) { s.iterations = 0; }, "iterations");
  refused([](FimmSpec& s) { s.measurement_covariance(1, 1) = -1.0; }, "measurement_covariance");
  refused([](FimmSpec& s) { s.sample_period = std::nan(""); }, "sample_period");
}

// Both filters of ImmTrackFilter<6> (the FIMM, the wIMM; a wrong-sized start used to reach the
// wIMM's fixed-size state unchecked) refuse a start they cannot take, by the field's name.
TEST(ImmTrackFilter, InvalidInitialStatesAreRefusedByName) {
  FimmSpec spec;
  spec.sample_period = 0.1;
  WimmSpec wimm_spec;
  wimm_spec.sample_period = 1.0;
  FimmFilter fimm(spec, nullptr);
  WimmFilter wimm(wimm_spec);
  for (TrackFilter* filter : std::initializer_list<TrackFilter*>{&fimm, &wimm}) {
    auto field_of = [&](const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) {
      try {
        filter->initialize(mean, covariance);
      } catch (const InvalidParameter& error) {
        return error.field();
      }
      return std::string();
    };
    const Eigen::VectorXd good = Eigen::VectorXd::Zero(6);
    EXPECT_EQ(field_of(good, start_covariance()), "");
    EXPECT_EQ(field_of(Eigen::VectorXd::Zero(4), start_covariance()), "initial_state");
    Eigen::VectorXd nan_mean = good;
    nan_mean(3) = std::nan("");
    EXPECT_EQ(field_of(nan_mean, start_covariance()), "initial_state");
    EXPECT_EQ(field_of(good, Eigen::MatrixXd::Identity(4, 4)), "initial_covariance");
    Eigen::MatrixXd skew = start_covariance();
    skew(0, 1) = 0.5;
    EXPECT_EQ(field_of(good, skew), "initial_covariance");
    Eigen::MatrixXd negative = start_covariance();
    negative(2, 2) = -1.0;
    EXPECT_EQ(field_of(good, negative), "initial_covariance");
  }
}

TEST(Fimm, ABadPlotLeavesTheFilterUnchanged) {
  FimmSpec spec;
  spec.sample_period = 0.1;
  FimmFilter fimm(spec, std::make_shared<const TskSensorModel>(sensor_like_model(TNorm::kMin)));
  Eigen::VectorXd start(6);
  start << 3.5, 0.0, 0.0, 20.0, 3.0, 0.0;
  fimm.initialize(start, start_covariance());
  ASSERT_EQ(fimm.step(Eigen::Vector2d(3.4, 20.2)), StepStatus::kOk);
  const GaussianState<6> before = fimm.estimate();
  EXPECT_NE(fimm.step(Eigen::Vector2d(std::nan(""), 20.0)), StepStatus::kOk);
  EXPECT_EQ(fimm.estimate().mean, before.mean);
  EXPECT_EQ(fimm.estimate().covariance, before.covariance);
}

}  // namespace
}  // namespace imm
