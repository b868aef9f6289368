// SPDX-License-Identifier: Apache-2.0
#pragma once
/// A range sensor known only through samples of it — (true position, output) pairs from a data
/// file — as a function the track simulator can measure through: "the sensor these samples came
/// from". Independent of any model fitted to the same samples (a FIMM fitted with
/// `imm-train tsk --data` is then evaluated on its own sensor, not on its own fit).
///
/// The response is a local quadratic regression of the samples, evaluated once on a regular grid
/// over the samples' box and interpolated bilinearly: at each grid node the k nearest samples (in
/// the box scaled to unit size) fit a quadratic in p − node by least squares with tricube
/// weights, and the node takes its constant term (a local linear fit would carry the distortion's
/// curvature into the response as a bias). Outside the box the response is that of the nearest
/// point of the box.

#include <Eigen/Core>

namespace imm::datasets {

class SampledSensor {
 public:
  /// positions, outputs: n × 2 each, n ≥ 10, finite. Throws InvalidParameter otherwise.
  SampledSensor(const Eigen::MatrixXd& positions, const Eigen::MatrixXd& outputs,
                int grid_points = 101, int neighbours = 128);

  /// The noise-free output at a position (clamped into the box).
  [[nodiscard]] Eigen::Vector2d response(const Eigen::Vector2d& position) const;
  [[nodiscard]] bool inside(const Eigen::Vector2d& position) const;
  [[nodiscard]] const Eigen::Vector2d& lower() const { return lower_; }
  [[nodiscard]] const Eigen::Vector2d& upper() const { return upper_; }

 private:
  Eigen::Vector2d lower_, upper_;
  int grid_ = 0;
  Eigen::MatrixXd nodes_[2];  ///< per output: grid × grid values, (ξ index, η index)
};

}  // namespace imm::datasets
