// SPDX-License-Identifier: Apache-2.0
#pragma once
// TSK sensor models the tests of seed 002's sensor, its FIMM and the FIMM's bank share.

#include <Eigen/Core>
#include <array>

#include "imm/models/learned/tsk_sensor_model.hpp"

namespace imm::testing {

// One TSK rule: centers (ξ, η), widths, consequent a₀ + a_ξ ξ + a_η η.
inline TskRule tsk_rule(double m_xi, double s_xi, double m_eta, double s_eta, double a0,
                        double a_xi, double a_eta) {
  TskRule r;
  r.center << m_xi, m_eta;
  r.width << s_xi, s_eta;
  r.consequent << a0, a_xi, a_eta;
  return r;
}

// Three rules per output, shaped like a fitted range-sensor model (saturating).
inline std::array<TskOutput, 2> sensor_like_outputs() {
  std::array<TskOutput, 2> outputs;
  outputs[0].rules = {tsk_rule(-3.0, 2.5, 15.0, 12.0, 0.1, 0.98, 0.002),
                      tsk_rule(0.5, 3.0, 50.0, 15.0, -0.2, 0.8, 0.01),
                      tsk_rule(2.0, 2.0, 85.0, 20.0, 0.3, 0.55, -0.004)};
  outputs[0].sigma = 0.05;
  outputs[1].rules = {tsk_rule(0.0, 4.0, 20.0, 14.0, 0.0, 0.01, 1.0),
                      tsk_rule(-1.0, 3.5, 55.0, 11.0, 9.0, -0.02, 0.7),
                      tsk_rule(1.0, 5.0, 90.0, 18.0, 38.0, 0.03, 0.25)};
  outputs[1].sigma = 0.07;
  return outputs;
}

// sensor_like_outputs on the box ξ ∈ [−6, 6], η ∈ [1, 100].
inline TskSensorModel sensor_like_model(TNorm t_norm, OutsideBox outside = OutsideBox::kLinear) {
  return TskSensorModel(sensor_like_outputs(), t_norm, Eigen::Vector2d(-6.0, 1.0),
                        Eigen::Vector2d(6.0, 100.0), outside);
}

}  // namespace imm::testing
