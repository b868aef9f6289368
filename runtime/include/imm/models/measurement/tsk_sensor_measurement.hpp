// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// A learned range sensor as an EKF measurement model: z = h(ξ, η) + v, h the TSK model
/// (tsk_sensor_model.hpp) of the position components, v ~ N(0, R + diag(σ₁², σ₂²)) — the sensor's
/// noise plus the model's own (seed 002 eq. 3, 7). The Jacobian is non-zero only in the two
/// position columns (the seed's ∇h after eq. 10, here for any state layout).

#include <Eigen/LU>
#include <array>
#include <memory>
#include <stdexcept>
#include <utility>

#include "imm/math/linear_algebra.hpp"
#include "imm/models/learned/tsk_sensor_model.hpp"

namespace imm {

/// The TSK sensor model as a measurement model of an N-state filter (the FIMM's EKF update).
template <int N>
class TskSensorMeasurement {
 public:
  /// The measurement dimension: (z1, z2).
  static constexpr int kDim = 2;

  /// `position_indices` = state indices of ξ and η; R the sensor's noise covariance.
  TskSensorMeasurement(std::shared_ptr<const TskSensorModel> model,
                       const std::array<int, 2>& position_indices, const SquareMatrix<2>& R)
      : model_(std::move(model)), indices_(position_indices) {
    if (!model_) throw std::invalid_argument("TSK sensor measurement: no model");
    for (int index : indices_) {
      if (index < 0 || index >= N) throw std::invalid_argument("position index outside the state");
    }
    if (!R.allFinite() || !(R(0, 0) > 0.0) || !(R.determinant() > 0.0)) {
      throw std::invalid_argument("measurement covariance R must be positive definite");
    }
    covariance_ = R + model_->noise_covariance();
  }

  /// h(x): the sensor model at the state's (ξ, η).
  [[nodiscard]] Vector<2> predict(const Vector<N>& x) const { return evaluate(x).value; }
  /// ∂h/∂x: the model's Jacobian placed at the (ξ, η) columns.
  [[nodiscard]] Matrix<2, N> jacobian(const Vector<N>& x) const {
    const TskEvaluation& e = evaluate(x);
    Matrix<2, N> H = Matrix<2, N>::Zero();
    H.col(indices_[0]) = e.jacobian.col(0);
    H.col(indices_[1]) = e.jacobian.col(1);
    return H;
  }
  /// z − h(x̂⁻).
  [[nodiscard]] Vector<2> residual(const Vector<2>& z, const Vector<2>& predicted) const {
    return z - predicted;
  }
  /// R.
  [[nodiscard]] const SquareMatrix<2>& covariance() const { return covariance_; }
  /// Whether the state is finite (the model is defined everywhere, clamped outside its box).
  [[nodiscard]] bool defined_at(const Vector<N>& x) const { return x.allFinite(); }

 private:
  [[nodiscard]] Eigen::Vector2d position(const Vector<N>& x) const {
    return {x(indices_[0]), x(indices_[1])};
  }
  // An update asks for h and H at the same point one after the other: h and ∇h come from one
  // TSK evaluation, kept for the last position asked (a per-filter cache; a filter is not shared
  // between threads while it steps).
  [[nodiscard]] const TskEvaluation& evaluate(const Vector<N>& x) const {
    const Eigen::Vector2d p = position(x);
    if (!cached_ || p != cached_at_) {
      last_ = model_->evaluate(p);
      cached_at_ = p;
      cached_ = true;
    }
    return last_;
  }

  std::shared_ptr<const TskSensorModel> model_;
  std::array<int, 2> indices_;
  SquareMatrix<2> covariance_;
  mutable Eigen::Vector2d cached_at_ = Eigen::Vector2d::Zero();
  mutable TskEvaluation last_;
  mutable bool cached_ = false;
};

}  // namespace imm
