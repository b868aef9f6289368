// SPDX-License-Identifier: Apache-2.0
#include "imm/datasets/range_sensor.hpp"

#include <cmath>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"

namespace imm::datasets {

void RangeDistortion::validate() const {
  require(knee > 0.0, "knee", "must be positive");
  limits::require_in(knee, limits::kDistance, "knee");
  require(softness > 0.0, "softness", "must be positive");
  limits::require_in(softness, limits::kDistance, "softness");
}

Eigen::Vector2d RangeDistortion::apply(const Eigen::Vector2d& position) const {
  const double eta = position(1);
  if (eta <= knee) return position;
  const double eta_m = knee + softness * std::tanh((eta - knee) / softness);
  return {position(0) * eta_m / eta, eta_m};
}

}  // namespace imm::datasets
