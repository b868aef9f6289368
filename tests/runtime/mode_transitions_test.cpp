// SPDX-License-Identifier: Apache-2.0
// Transition probabilities from a continuous-time generator, against the two-mode closed form.
#include "imm/estimation/mode_transitions.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "imm/core/invalid_parameter.hpp"

namespace imm {
namespace {

TEST(ModeTransitions, TwoModesMatchTheClosedForm) {
  // Π01(T) = q01 / (q01 + q10) · (1 − e^{−(q01 + q10) T}).
  for (const double T : {0.1, 1.0, 5.0}) {
    const double a = 1.0 / 40.0, b = 1.0 / 12.0;
    const Eigen::MatrixXd p = transition_matrix(two_mode_generator(40.0, 12.0), T);
    const double decay = 1.0 - std::exp(-(a + b) * T);
    EXPECT_NEAR(p(0, 1), a / (a + b) * decay, 1e-14) << T;
    EXPECT_NEAR(p(1, 0), b / (a + b) * decay, 1e-14) << T;
    EXPECT_NEAR(p(0, 0) + p(0, 1), 1.0, 1e-15);
    EXPECT_NEAR(p(1, 0) + p(1, 1), 1.0, 1e-15);
  }
}

TEST(ModeTransitions, ASamplePeriodTwiceAsLongIsTheSquare) {
  Eigen::MatrixXd q(3, 3);
  q << -0.10, 0.06, 0.04, 0.20, -0.30, 0.10, 0.0, 0.5, -0.5;
  const Eigen::MatrixXd once = transition_matrix(q, 0.7);
  EXPECT_LT((transition_matrix(q, 1.4) - once * once).cwiseAbs().maxCoeff(), 1e-13);
}

TEST(ModeTransitions, AnInvalidGeneratorIsRefusedNamingIt) {
  const auto field_of = [](const Eigen::MatrixXd& q) {
    try {
      (void)transition_matrix(q, 1.0);
    } catch (const InvalidParameter& error) {
      return error.field();
    }
    return std::string("accepted");
  };
  Eigen::MatrixXd q(2, 2);
  q << -0.1, 0.1, 0.2, -0.1;
  EXPECT_EQ(field_of(q), "generator");  // a row that does not sum to zero
  q << 0.1, -0.1, 0.2, -0.2;
  EXPECT_EQ(field_of(q), "generator[0][1]");  // a negative rate
  q << -0.1, 0.1, std::nan(""), 0.0;
  EXPECT_EQ(field_of(q), "generator");
  EXPECT_EQ(field_of(Eigen::MatrixXd::Zero(2, 3)), "generator");
  try {
    (void)transition_matrix(two_mode_generator(10.0, 5.0), 0.0);
    ADD_FAILURE();
  } catch (const InvalidParameter& error) {
    EXPECT_EQ(error.field(), "sample_period");
  }
}

}  // namespace
}  // namespace imm
