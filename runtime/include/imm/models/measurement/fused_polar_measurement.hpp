// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The polar plot model of seed 004's weighted IMM, three ways (the per-cycle choice is shared by
/// every mode through AzimuthFusion, set by the filter before the update):
///
/// - kPlot: the plain polar EKF model, z = [r, θ] (the normal IMM).
/// - kSeed: the seed's reading. The plot's azimuth is replaced by the fused θ_f = θ̄ + α (θ_p − θ̄)
///   (eq. 8; α θ_p + (1 − α) θ̄ on the circle) and treated as an ordinary plot with R unchanged.
///   Linearized for one model, the innovation becomes α ν_θ: the state moves by α K ν while P
///   shrinks as if by K ν — the filter halves its azimuth gain without telling its covariance.
/// - kCorrelated: the fused plot modelled honestly. With A = diag(1, α), z_f = A z + (I − A) c,
///   c = [·, θ̄] known; then ν_f = A ν, var(ν_f) = A S Aᵀ, cov(x, ν_f) = P Hᵀ Aᵀ, i.e. an EKF with
///   h_f(x) = A h(x) + (I − A) c, Jacobian A H and covariance A R Aᵀ. Its gain is K A⁻¹, so the
///   update is exactly the normal IMM's (and every mode's likelihood changes by the same factor
///   1/|det A|): fusing the prediction into the plot adds no information.
///
/// - kConverted: a converted-measurement alternative to the EKF: the plot becomes a Cartesian
///   position with the linearized covariance J R Jᵀ and a linear update (set per cycle).

#include <cmath>
#include <memory>

#include "imm/math/angle.hpp"
#include "imm/models/measurement/polar_measurement.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// Which azimuth the update uses: the plot's, the seed's fused one, the correlated fusion, or the
/// converted Cartesian plot.
enum class AzimuthUse { kPlot, kSeed, kCorrelated, kConverted };

/// The fusion of the current cycle.
struct IMM_RUNTIME_EXPORT AzimuthFusion {
  /// The azimuth the update uses this cycle.
  AzimuthUse use = AzimuthUse::kPlot;
  double alpha = 1.0;              ///< weight of the plot azimuth (kSeed, kCorrelated)
  double predicted_azimuth = 0.0;  ///< θ̄ (kCorrelated)
  SquareMatrix<2> converted_covariance = SquareMatrix<2>::Identity();  ///< kConverted
};

/// A polar measurement whose azimuth may be fused with the prediction's, as the shared
/// AzimuthFusion says for the current cycle (the WIMM's update).
template <int N>
class FusedPolarMeasurement {
 public:
  /// The measurement dimension: (range, azimuth).
  static constexpr int kDim = 2;

  /// Position at state indices x_index, y_index; R = diag(σ_R², σ_θ²); `fusion` set by the filter
  /// before each cycle.
  FusedPolarMeasurement(int x_index, int y_index, const SquareMatrix<2>& R,
                        std::shared_ptr<const AzimuthFusion> fusion)
      : polar_(x_index, y_index, R),
        x_index_(x_index),
        y_index_(y_index),
        R_(R),
        fusion_(std::move(fusion)) {}

  /// h(x): range and azimuth of the position.
  [[nodiscard]] Vector<2> predict(const Vector<N>& x) const {
    if (fusion_->use == AzimuthUse::kConverted) return Vector<2>(x(x_index_), x(y_index_));
    Vector<2> h = polar_.predict(x);
    if (fusion_->use == AzimuthUse::kCorrelated) {
      const double theta_bar = fusion_->predicted_azimuth;
      h(1) = theta_bar + fusion_->alpha * wrap_angle(h(1) - theta_bar);
    }
    return h;
  }

  /// ∂h/∂x at x.
  [[nodiscard]] Matrix<2, N> jacobian(const Vector<N>& x) const {
    if (fusion_->use == AzimuthUse::kConverted) {
      Matrix<2, N> H = Matrix<2, N>::Zero();
      H(0, x_index_) = 1.0;
      H(1, y_index_) = 1.0;
      return H;
    }
    Matrix<2, N> H = polar_.jacobian(x);
    if (fusion_->use == AzimuthUse::kCorrelated) H.row(1) *= fusion_->alpha;
    return H;
  }

  /// z is the (possibly fused) polar plot; kConverted compares positions.
  [[nodiscard]] Vector<2> residual(const Vector<2>& z, const Vector<2>& predicted) const {
    if (fusion_->use == AzimuthUse::kConverted) {
      return Vector<2>(z(0) * std::sin(z(1)), z(0) * std::cos(z(1))) - predicted;
    }
    return polar_.residual(z, predicted);
  }

  /// R of the current cycle's azimuth use.
  [[nodiscard]] const SquareMatrix<2>& covariance() const {
    switch (fusion_->use) {
      case AzimuthUse::kCorrelated: {
        correlated_covariance_ = R_;
        correlated_covariance_.row(1) *= fusion_->alpha;
        correlated_covariance_.col(1) *= fusion_->alpha;
        return correlated_covariance_;
      }
      case AzimuthUse::kConverted:
        return fusion_->converted_covariance;
      default:
        return R_;
    }
  }

  /// Whether h and its Jacobian are defined at x (range above the minimum).
  [[nodiscard]] bool defined_at(const Vector<N>& x) const {
    return fusion_->use == AzimuthUse::kConverted || polar_.defined_at(x);
  }

 private:
  PolarMeasurement<N> polar_;
  int x_index_, y_index_;
  SquareMatrix<2> R_;
  std::shared_ptr<const AzimuthFusion> fusion_;
  mutable SquareMatrix<2> correlated_covariance_ = SquareMatrix<2>::Identity();
};

}  // namespace imm
