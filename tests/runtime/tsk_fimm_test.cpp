// SPDX-License-Identifier: Apache-2.0
// The TSK sensor model and the fuzzy IMM of seed 002: h and its Jacobian against hand values and
// central differences, the outside-box policies, the iterated EKF against the EKF (linear h) and
// against the MAP point (nonlinear h), the FIMM with an identity sensor against the plain IMM, and
// the tsk_sensor model file.

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <initializer_list>
#include <memory>
#include <string>

#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/range_sensor.hpp"
#include "imm/estimation/kalman_filter.hpp"
#include "imm/filters/fimm.hpp"
#include "imm/filters/wimm.hpp"
#include "imm/io/file_error.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/models/learned/tsk_sensor_model.hpp"
#include "imm/models/measurement/tsk_sensor_measurement.hpp"
#include "testing/model_files.hpp"
#include "testing/regimes.hpp"
#include "testing/temp_dir.hpp"
#include "testing/tsk_sensors.hpp"

namespace imm {
namespace {

const std::vector<std::string> kRuleColumns = {"center_xi", "width_xi", "center_eta", "width_eta",
                                               "a0",        "a_xi",     "a_eta"};

using testing::sensor_like_model;
using testing::sensor_like_outputs;
using testing::tsk_rule;

/// An exact identity sensor: one rule per output, z₁ = ξ, z₂ = η, σ = 0, a box nothing leaves.
std::shared_ptr<const TskSensorModel> identity_sensor() {
  std::array<TskOutput, 2> outputs;
  outputs[0].rules = {tsk_rule(0.0, 1e3, 0.0, 1e3, 0.0, 1.0, 0.0)};
  outputs[1].rules = {tsk_rule(0.0, 1e3, 0.0, 1e3, 0.0, 0.0, 1.0)};
  return std::make_shared<const TskSensorModel>(
      outputs, TNorm::kMin, Eigen::Vector2d::Constant(-1e6), Eigen::Vector2d::Constant(1e6));
}

/// Membership logs of every rule of both outputs at x: used to stay away from min-ties.
double smallest_tie_gap(const TskSensorModel& model, const Eigen::Vector2d& x) {
  double gap = 1e300;
  for (const TskOutput& out : model.outputs()) {
    for (const TskRule& r : out.rules) {
      const Eigen::Array2d u = (x - r.center).array() / r.width.array();
      gap = std::min(gap, std::abs(u(0) * u(0) - u(1) * u(1)));
    }
  }
  return gap;
}

// --- h and ∇h -------------------------------------------------------------------------------

TEST(TskSensorModel, OneRuleIsItsHyperplane) {
  std::array<TskOutput, 2> outputs;
  outputs[0].rules = {tsk_rule(1.0, 2.0, 3.0, 4.0, 0.5, 2.0, -1.0)};
  outputs[1].rules = {tsk_rule(-1.0, 1.0, 30.0, 9.0, -3.0, 0.25, 0.75)};
  const TskSensorModel model(outputs, TNorm::kProduct, Eigen::Vector2d(-10, -10),
                             Eigen::Vector2d(10, 100));
  const TskEvaluation e = model.evaluate(Eigen::Vector2d(2.0, 7.0));
  EXPECT_DOUBLE_EQ(e.value(0), 0.5 + 2.0 * 2.0 - 7.0);
  EXPECT_DOUBLE_EQ(e.value(1), -3.0 + 0.25 * 2.0 + 0.75 * 7.0);
  EXPECT_DOUBLE_EQ(e.jacobian(0, 0), 2.0);
  EXPECT_DOUBLE_EQ(e.jacobian(0, 1), -1.0);
  EXPECT_DOUBLE_EQ(e.jacobian(1, 0), 0.25);
  EXPECT_DOUBLE_EQ(e.jacobian(1, 1), 0.75);
  EXPECT_FALSE(e.clamped);
}

TEST(TskSensorModel, TwoRulesByHand) {
  // Rules at ξ-centers 0 and 2 (width 1), η-centers 0 (width 1); at x = (1, 0.5):
  // A_ξ = e^{−1/2} for both, A_η = e^{−1/8} for both. Product and min both give equal weights,
  // so h = (z¹ + z²)/2 with z¹ = 1 + 1·1 = 2, z² = 3 · 0.5 = 1.5 → 1.75.
  std::array<TskOutput, 2> outputs;
  outputs[0].rules = {tsk_rule(0.0, 1.0, 0.0, 1.0, 1.0, 1.0, 0.0),
                      tsk_rule(2.0, 1.0, 0.0, 1.0, 0.0, 0.0, 3.0)};
  outputs[1] = outputs[0];
  for (TNorm t : {TNorm::kProduct, TNorm::kMin}) {
    const TskSensorModel model(outputs, t, Eigen::Vector2d(-5, -5), Eigen::Vector2d(5, 5));
    const TskEvaluation e = model.evaluate(Eigen::Vector2d(1.0, 0.5));
    EXPECT_NEAR(e.value(0), 1.75, 1e-15);
    // ∂h/∂ξ = Σ w [∂log w/∂ξ (z − h) + a_ξ] / Σ w. The ξ-memberships decide the min too here
    // (|u_ξ| = 1 > |u_η| = 0.5): ∂log w¹/∂ξ = −1, ∂log w²/∂ξ = +1:
    // [(−1)(2 − 1.75) + 1 + (1)(1.5 − 1.75) + 0] / 2 = 0.25.
    EXPECT_NEAR(e.jacobian(0, 0), 0.25, 1e-15);
    // ∂h/∂η: product: ∂log w/∂η = −0.5 for both → [−0.5·0.25 + 0 − 0.5·(−0.25) + 3]/2 = 1.5;
    // min: the ξ-memberships are the minimum, so ∂log w/∂η = 0 → (0 + 3)/2 = 1.5 as well.
    EXPECT_NEAR(e.jacobian(0, 1), 1.5, 1e-15);
  }
}

TEST(TskSensorModel, JacobianMatchesCentralDifferences) {
  for (TNorm t : {TNorm::kProduct, TNorm::kMin}) {
    const TskSensorModel model = sensor_like_model(t);
    int checked = 0;
    for (double xi = -5.5; xi <= 5.5; xi += 1.37) {
      for (double eta = 2.0; eta <= 99.0; eta += 6.1) {
        const Eigen::Vector2d x(xi, eta);
        if (t == TNorm::kMin && smallest_tie_gap(model, x) < 1e-3) continue;  // a kink
        const TskEvaluation e = model.evaluate(x);
        for (int s = 0; s < 2; ++s) {
          const double step = 1e-6 * std::max(1.0, std::abs(x(s)));
          Eigen::Vector2d up = x, down = x;
          up(s) += step;
          down(s) -= step;
          const Eigen::Vector2d fd =
              (model.evaluate(up).value - model.evaluate(down).value) / (2.0 * step);
          for (int i = 0; i < 2; ++i) {
            EXPECT_NEAR(e.jacobian(i, s), fd(i), 1e-6 * std::max(1.0, std::abs(fd(i))))
                << to_string(t) << " x = " << x.transpose() << " output " << i << " input " << s;
          }
        }
        ++checked;
      }
    }
    EXPECT_GT(checked, 100) << to_string(t);
  }
}

TEST(TskSensorModel, FarFromEveryCenterTheWeightsDoNotUnderflow) {
  // 40 widths from every center every exp(−u²/2) underflows in linear space; the log-space
  // weights keep h the consequent of the nearest rule (in units of its widths).
  std::array<TskOutput, 2> outputs;
  outputs[0].rules = {tsk_rule(0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0),
                      tsk_rule(10.0, 1.0, 0.0, 1.0, 2.0, 0.0, 0.0)};
  outputs[1] = outputs[0];
  const TskSensorModel model(outputs, TNorm::kProduct, Eigen::Vector2d(-1e3, -1e3),
                             Eigen::Vector2d(1e3, 1e3));
  const TskEvaluation e = model.evaluate(Eigen::Vector2d(60.0, 0.0));
  ASSERT_TRUE(e.value.allFinite());
  ASSERT_TRUE(e.jacobian.allFinite());
  EXPECT_NEAR(e.value(0), 2.0, 1e-12);
}

// --- Outside the trained box ------------------------------------------------------------------

TEST(TskSensorModel, OutsideTheBoxLinearContinuesFromTheClampedPoint) {
  const TskSensorModel model = sensor_like_model(TNorm::kProduct, OutsideBox::kLinear);
  const Eigen::Vector2d edge(2.0, 100.0);
  const TskEvaluation at_edge = model.evaluate(edge);
  EXPECT_FALSE(at_edge.clamped);
  for (double beyond : {1.0, 50.0, 1e4}) {
    const Eigen::Vector2d x(2.0, 100.0 + beyond);
    const TskEvaluation e = model.evaluate(x);
    EXPECT_TRUE(e.clamped);
    const Eigen::Vector2d expected = at_edge.value + at_edge.jacobian * (x - edge);
    EXPECT_NEAR((e.value - expected).norm(), 0.0, 1e-9 * expected.norm());
    EXPECT_EQ(e.jacobian, at_edge.jacobian);
  }
  // Continuous across the boundary.
  const TskEvaluation just_out = model.evaluate(Eigen::Vector2d(2.0, 100.0 + 1e-9));
  EXPECT_NEAR((just_out.value - at_edge.value).norm(), 0.0, 1e-8);
  // Both inputs outside (beside and behind the host): the corner is the clamped point.
  const TskEvaluation corner = model.evaluate(Eigen::Vector2d(-6.0, 1.0));
  const Eigen::Vector2d x(-9.0, -4.0);
  const TskEvaluation e = model.evaluate(x);
  EXPECT_TRUE(e.clamped);
  EXPECT_NEAR((e.value - (corner.value + corner.jacobian * Eigen::Vector2d(-3.0, -5.0))).norm(),
              0.0, 1e-12);
}

TEST(TskSensorModel, OutsideTheBoxHoldFreezesTheValueAndZeroesTheClampedColumn) {
  const TskSensorModel model = sensor_like_model(TNorm::kMin, OutsideBox::kHold);
  const TskEvaluation edge = model.evaluate(Eigen::Vector2d(1.5, 100.0));
  const TskEvaluation e = model.evaluate(Eigen::Vector2d(1.5, 400.0));
  EXPECT_TRUE(e.clamped);
  EXPECT_EQ(e.value, edge.value);
  EXPECT_EQ(e.jacobian.col(0), edge.jacobian.col(0));  // ξ is inside: its slope stays
  EXPECT_EQ(e.jacobian.col(1), Eigen::Vector2d::Zero());
}

TEST(TskSensorModel, InvalidRulesAreRefusedByName) {
  auto refused = [](const std::function<void()>& make, const std::string& field) {
    try {
      make();
      ADD_FAILURE() << field << ": accepted";
    } catch (const InvalidParameter& error) {
      EXPECT_EQ(error.field(), field) << error.what();
    }
  };
  const Eigen::Vector2d lo(-6.0, 1.0), hi(6.0, 100.0);
  refused(
      [&] {
        auto o = sensor_like_outputs();
        o[1].rules[2].width(1) = 0.0;
        (void)TskSensorModel(o, TNorm::kMin, lo, hi);
      },
      "outputs[1].rules[2].width");
  refused(
      [&] {
        auto o = sensor_like_outputs();
        o[0].rules[1].consequent(0) = std::nan("");
        (void)TskSensorModel(o, TNorm::kMin, lo, hi);
      },
      "outputs[0].rules[1].consequent");
  refused(
      [&] {
        auto o = sensor_like_outputs();
        o[0].sigma = -0.1;
        (void)TskSensorModel(o, TNorm::kMin, lo, hi);
      },
      "outputs[0].sigma");
  refused(
      [&] {
        auto o = sensor_like_outputs();
        o[1].rules.clear();
        (void)TskSensorModel(o, TNorm::kMin, lo, hi);
      },
      "outputs[1].rules");
  refused([&] { (void)TskSensorModel(sensor_like_outputs(), TNorm::kMin, hi, lo); }, "input_upper");
  // Degenerate but finite values that would make the evaluation overflow or divide 0 by 0.
  refused(
      [&] {
        auto o = sensor_like_outputs();
        o[0].rules[0].width(0) = 1e-300;
        (void)TskSensorModel(o, TNorm::kMin, lo, hi);
      },
      "outputs[0].rules[0].width");
  refused(
      [&] {
        auto o = sensor_like_outputs();
        o[1].rules[1].center(1) = 1e300;
        (void)TskSensorModel(o, TNorm::kMin, lo, hi);
      },
      "outputs[1].rules[1].center");
  refused(
      [&] {
        auto o = sensor_like_outputs();
        o[1].rules[0].consequent(2) = 1e307;
        (void)TskSensorModel(o, TNorm::kProduct, lo, hi);
      },
      "outputs[1].rules");
  refused([&] { (void)t_norm_from("max", "t_norm"); }, "t_norm");
}

TEST(TskSensorMeasurement, JacobianGoesToThePositionColumns) {
  const auto model = std::make_shared<const TskSensorModel>(sensor_like_model(TNorm::kProduct));
  const TskSensorMeasurement<6> h(model, {0, 3}, 0.25 * SquareMatrix<2>::Identity());
  Vector<6> x;
  x << 1.2, 0.3, -0.1, 47.0, 3.0, 0.2;
  const TskEvaluation e = model->evaluate(Eigen::Vector2d(1.2, 47.0));
  EXPECT_EQ(h.predict(x), e.value);
  const Matrix<2, 6> H = h.jacobian(x);
  EXPECT_EQ(H.col(0), e.jacobian.col(0));
  EXPECT_EQ(H.col(3), e.jacobian.col(1));
  for (int c : {1, 2, 4, 5}) EXPECT_EQ(H.col(c), Eigen::Vector2d::Zero()) << c;
  // R + diag(σ²).
  EXPECT_DOUBLE_EQ(h.covariance()(0, 0), 0.25 + 0.05 * 0.05);
  EXPECT_DOUBLE_EQ(h.covariance()(1, 1), 0.25 + 0.07 * 0.07);
  EXPECT_EQ(h.covariance()(0, 1), 0.0);
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

// --- Model file -----------------------------------------------------------------------------
// (Non-finite numbers cannot be written by the writer at all; the generic reader's refusal of
// them is drilled in model_file_test.cpp.)

void write(const std::filesystem::path& path, const TskSensorModel& model,
           const std::function<void(io::ModelFileWriter&)>& tamper = {}) {
  testing::write_model(path, io::kTskSensorKind, [&](io::ModelFileWriter& writer) {
    io::write_tsk_sensor(writer, model);
    if (tamper) tamper(writer);
  });
}

TEST(TskSensorFile, RoundTrip) {
  const testing::TempDir dir;
  for (TNorm t : {TNorm::kMin, TNorm::kProduct}) {
    const TskSensorModel model = sensor_like_model(t);
    write(dir / "tsk.h5", model);
    const TskSensorModel back = io::read_tsk_sensor(dir / "tsk.h5");
    EXPECT_EQ(back.t_norm(), t);
    EXPECT_EQ(back.input_lower(), model.input_lower());
    EXPECT_EQ(back.input_upper(), model.input_upper());
    EXPECT_EQ(back.outside_policy(), OutsideBox::kLinear);
    for (int i = 0; i < 2; ++i) {
      const auto& a = model.outputs()[static_cast<std::size_t>(i)];
      const auto& b = back.outputs()[static_cast<std::size_t>(i)];
      EXPECT_EQ(a.sigma, b.sigma);
      EXPECT_EQ(io::rules_matrix(a.rules), io::rules_matrix(b.rules));
    }
    for (const Eigen::Vector2d& x : {Eigen::Vector2d(0.3, 44.0), Eigen::Vector2d(-9.0, 130.0)}) {
      EXPECT_EQ(model.evaluate(x).value, back.evaluate(x).value);
      EXPECT_EQ(model.evaluate(x).jacobian, back.evaluate(x).jacobian);
    }
  }
}

TEST(TskSensorFile, HostileValuesAreRefusedByName) {
  const testing::TempDir dir;
  const TskSensorModel model = sensor_like_model(TNorm::kMin);
  auto refused = [&](const std::string& name, const std::function<void(io::ModelFileWriter&)>& f,
                     const std::string& field) {
    write(dir / (name + ".h5"), model, f);
    try {
      (void)io::read_tsk_sensor(dir / (name + ".h5"));
      ADD_FAILURE() << name << ": accepted";
    } catch (const io::FileError& error) {
      EXPECT_NE(std::string(error.what()).find(field), std::string::npos)
          << name << ": " << error.what();
    }
  };
  refused(
      "t_norm", [](auto& w) { w.set_attribute("/tsk", "t_norm", std::string("max")); },
      "/tsk@t_norm");
  refused(
      "sigma", [](auto& w) { w.set_quantity("/tsk/output2", "sigma", -0.5, "m"); },
      "/tsk/output2@sigma");
  refused(
      "width",
      [&](auto& w) {
        Eigen::MatrixXd rules = io::rules_matrix(model.outputs()[0].rules);
        rules(1, 3) = 0.0;
        w.write_matrix("/tsk/output1/rules", rules, kRuleColumns, "m");
      },
      "/tsk/output1/rules");
  refused(
      "columns",
      [](auto& w) {
        w.write_matrix("/tsk/output1/rules", Eigen::MatrixXd::Ones(3, 6),
                       {"a", "b", "c", "d", "e", "f"}, "m");
      },
      "/tsk/output1/rules");
  refused(
      "too_many",
      [](auto& w) {
        Eigen::MatrixXd rules = Eigen::MatrixXd::Ones(TskSensorModel::kMaxRules + 1, 7);
        w.write_matrix("/tsk/output1/rules", rules, kRuleColumns, "m");
      },
      "/tsk/output1/rules");
  refused(
      "tiny_width",
      [&](auto& w) {
        Eigen::MatrixXd rules = io::rules_matrix(model.outputs()[1].rules);
        rules(2, 1) = 1e-300;
        w.write_matrix("/tsk/output2/rules", rules, kRuleColumns, "m");
      },
      "/tsk/output2/rules");
  refused(
      "huge_consequent",
      [&](auto& w) {
        Eigen::MatrixXd rules = io::rules_matrix(model.outputs()[0].rules);
        rules(0, 5) = 1e308;  // a_xi: overflows at the box corners
        w.write_matrix("/tsk/output1/rules", rules, kRuleColumns, "m");
      },
      "/tsk/output1/rules");
  refused(
      "box",
      [](auto& w) {
        w.write_matrix("/tsk/input_box", (Eigen::Matrix2d() << 6, 100, -6, 1).finished(),
                       {"xi", "eta"}, "m");
      },
      "/tsk/input_box");
}

}  // namespace
}  // namespace imm
