// SPDX-License-Identifier: Apache-2.0
// The TSK sensor model of seed 002: h and its Jacobian against hand values and central
// differences, the outside-box policies, refused rules, and the tsk_sensor model file (the
// iterated EKF and the FIMM are in fimm_test.cpp).

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>
#include <string>

#include "imm/core/invalid_parameter.hpp"
#include "imm/io/file_error.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/models/learned/tsk_sensor_model.hpp"
#include "imm/models/measurement/tsk_sensor_measurement.hpp"
#include "testing/model_files.hpp"
#include "testing/temp_dir.hpp"
#include "testing/tsk_sensors.hpp"

namespace imm {
namespace {

const std::vector<std::string> kRuleColumns = {"center_xi", "width_xi", "center_eta", "width_eta",
                                               "a0",        "a_xi",     "a_eta"};

using testing::sensor_like_model;
using testing::sensor_like_outputs;
using testing::tsk_rule;

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
