// SPDX-License-Identifier: Apache-2.0
#include "imm/datasets/sampled_sensor.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include "imm/core/invalid_parameter.hpp"

namespace imm::datasets {
namespace {
using Matrix6 = Eigen::Matrix<double, 6, 6>;
}  // namespace

SampledSensor::SampledSensor(const Eigen::MatrixXd& positions, const Eigen::MatrixXd& outputs,
                             int grid_points, int neighbours)
    : grid_(grid_points) {
  const Eigen::Index n = positions.rows();
  require(positions.cols() == 2 && outputs.cols() == 2 && outputs.rows() == n && n >= 10, "samples",
          "need n × 2 positions and outputs, n ≥ 10");
  require(positions.allFinite() && outputs.allFinite(), "samples", "must be finite");
  require(grid_points >= 2 && neighbours >= 3, "samples", "grid ≥ 2 points, ≥ 3 neighbours");
  lower_ = positions.colwise().minCoeff().transpose();
  upper_ = positions.colwise().maxCoeff().transpose();
  require(((upper_ - lower_).array() > 0.0).all(), "samples", "must span a box in ξ and η");
  const Eigen::Vector2d span = upper_ - lower_;
  const Eigen::MatrixXd scaled =
      (positions.rowwise() - lower_.transpose()).array().rowwise() / span.transpose().array();
  const auto k = static_cast<std::size_t>(std::min<Eigen::Index>(neighbours, n));
  std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
  Eigen::VectorXd distance(n);
  for (Eigen::MatrixXd& node : nodes_) node.resize(grid_, grid_);
  for (int i = 0; i < grid_; ++i) {
    for (int j = 0; j < grid_; ++j) {
      const Eigen::RowVector2d at(static_cast<double>(i) / (grid_ - 1),
                                  static_cast<double>(j) / (grid_ - 1));
      distance = (scaled.rowwise() - at).rowwise().norm();
      std::iota(order.begin(), order.end(), Eigen::Index{0});
      std::nth_element(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(k - 1),
                       order.end(),
                       [&](Eigen::Index a, Eigen::Index b) { return distance(a) < distance(b); });
      double radius = 0.0;
      for (std::size_t q = 0; q < k; ++q) radius = std::max(radius, distance(order[q]));
      radius = std::max(radius * 1.0001, 1e-12);
      Matrix6 A = Matrix6::Zero();
      Eigen::Matrix<double, 6, 2> b = Eigen::Matrix<double, 6, 2>::Zero();
      for (std::size_t q = 0; q < k; ++q) {
        const Eigen::Index s = order[q];
        const double u = distance(s) / radius;
        const double weight = std::pow(1.0 - u * u * u, 3.0);  // tricube
        const double dx = (scaled(s, 0) - at(0)) / radius, dy = (scaled(s, 1) - at(1)) / radius;
        Eigen::Matrix<double, 6, 1> x;
        x << 1.0, dx, dy, dx * dx, dx * dy, dy * dy;
        A += weight * x * x.transpose();
        b += weight * x * outputs.row(s);
      }
      // A ridge on the slopes and curvatures keeps the fit defined where the neighbours are
      // collinear.
      A.diagonal().tail<5>().array() += 1e-9;
      const Eigen::Matrix<double, 6, 2> coefficients = A.ldlt().solve(b);
      nodes_[0](i, j) = coefficients(0, 0);
      nodes_[1](i, j) = coefficients(0, 1);
    }
  }
}

bool SampledSensor::inside(const Eigen::Vector2d& position) const {
  return (position.array() >= lower_.array()).all() && (position.array() <= upper_.array()).all();
}

Eigen::Vector2d SampledSensor::response(const Eigen::Vector2d& position) const {
  const Eigen::Vector2d unit =
      ((position - lower_).array() / (upper_ - lower_).array()).cwiseMax(0.0).cwiseMin(1.0);
  const double gi = unit(0) * (grid_ - 1), gj = unit(1) * (grid_ - 1);
  const int i = std::min(static_cast<int>(gi), grid_ - 2);
  const int j = std::min(static_cast<int>(gj), grid_ - 2);
  const double fi = gi - i, fj = gj - j;
  Eigen::Vector2d value;
  for (int o = 0; o < 2; ++o) {
    const Eigen::MatrixXd& v = nodes_[o];
    value(o) = (1.0 - fi) * ((1.0 - fj) * v(i, j) + fj * v(i, j + 1)) +
               fi * ((1.0 - fj) * v(i + 1, j) + fj * v(i + 1, j + 1));
  }
  return value;
}

}  // namespace imm::datasets
