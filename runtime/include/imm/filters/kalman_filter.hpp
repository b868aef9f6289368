#pragma once
/// The Kalman algebra, written once: prediction, the Joseph-form measurement update, and the
/// extended (linearized) update through a measurement model. Every filter of the runtime — plain
/// KF, IMM mode, fuzzy-noise KF, EKF through a learned sensor model — calls these functions and
/// changes only what it feeds them (F, Q, the input, h and its Jacobian).
///
/// References: seed 000 eq. (7-1)–(7-7); the covariance update is the Joseph form
/// P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ, which stays symmetric positive semi-definite for any gain
/// and therefore survives extreme noise ratios where P − K S Kᵀ loses definiteness.

#include <cmath>
#include <numbers>

#include <Eigen/Cholesky>

#include "imm/filters/gaussian_state.hpp"
#include "imm/filters/step_status.hpp"
#include "imm/math/linear_algebra.hpp"

namespace imm {

/// What a measurement update reports besides the new state.
template <int M>
struct UpdateReport {
  StepStatus status = StepStatus::kOk;
  Vector<M> innovation = Vector<M>::Zero();                ///< ν = z − h(x̂⁻), wrapped if angular
  SquareMatrix<M> innovation_covariance = SquareMatrix<M>::Zero();  ///< S = H P⁻ Hᵀ + R
  double log_likelihood = 0.0;  ///< log N(ν; 0, S), seed 000 eq. (9) in log space

  [[nodiscard]] bool ok() const { return status == StepStatus::kOk; }
};

/// Time update x⁻ = F x, P⁻ = F P Fᵀ + Q (seed 000 eq. 7-1, 7-2 without input).
template <int N>
[[nodiscard]] GaussianState<N> predict(const GaussianState<N>& state, const SquareMatrix<N>& F,
                                       const SquareMatrix<N>& Q) {
  GaussianState<N> predicted;
  predicted.mean.noalias() = F * state.mean;
  predicted.covariance.noalias() = F * state.covariance * F.transpose();
  predicted.covariance += Q;
  predicted.covariance = symmetrized(predicted.covariance);
  return predicted;
}

/// Time update with a known input: x⁻ = F x + B u (seed 000 eq. 7-1, seed 001 eq. 10).
template <int N, int U>
[[nodiscard]] GaussianState<N> predict(const GaussianState<N>& state, const SquareMatrix<N>& F,
                                       const SquareMatrix<N>& Q, const Matrix<N, U>& B,
                                       const Vector<U>& u) {
  GaussianState<N> predicted = predict(state, F, Q);
  predicted.mean.noalias() += B * u;
  return predicted;
}

/// Joseph-form update from a given innovation ν and measurement matrix H (the Jacobian for an
/// EKF). On any status other than kOk `state` is left exactly as it was.
template <int N, int M>
UpdateReport<M> update_with_innovation(GaussianState<N>& state, const Vector<M>& innovation,
                                       const Matrix<M, N>& H, const SquareMatrix<M>& R) {
  UpdateReport<M> report;
  report.innovation = innovation;
  const Matrix<N, M> PHt = state.covariance * H.transpose();
  report.innovation_covariance = symmetrized(H * PHt + R);

  const Eigen::LLT<SquareMatrix<M>> llt(report.innovation_covariance);
  if (llt.info() != Eigen::Success || !report.innovation_covariance.allFinite()) {
    report.status = StepStatus::kSingularInnovation;
    return report;
  }
  const SquareMatrix<M> L = llt.matrixL();
  double log_det = 0.0;
  for (int i = 0; i < M; ++i) {
    if (!(L(i, i) > 0.0)) {
      report.status = StepStatus::kSingularInnovation;
      return report;
    }
    log_det += 2.0 * std::log(L(i, i));
  }

  // K = P Hᵀ S⁻¹, solved rather than inverted.
  const Matrix<N, M> K = llt.solve(PHt.transpose()).transpose();
  const SquareMatrix<N> I_KH = SquareMatrix<N>::Identity() - K * H;
  GaussianState<N> updated;
  updated.mean = state.mean + K * innovation;
  updated.covariance.noalias() = I_KH * state.covariance * I_KH.transpose();
  updated.covariance.noalias() += K * R * K.transpose();
  updated.covariance = symmetrized(updated.covariance);
  if (!updated.all_finite()) {
    report.status = StepStatus::kNonFiniteResult;
    return report;
  }

  const double mahalanobis = innovation.dot(llt.solve(innovation));
  report.log_likelihood =
      -0.5 * (mahalanobis + log_det + M * std::log(2.0 * std::numbers::pi));
  state = updated;
  return report;
}

/// Linear Kalman measurement update, z = H x + v, v ~ N(0, R) (seed 000 eq. 7-3–7-7).
template <int N, int M>
UpdateReport<M> update(GaussianState<N>& state, const Vector<M>& z, const Matrix<M, N>& H,
                       const SquareMatrix<M>& R) {
  if (!z.allFinite()) {
    UpdateReport<M> report;
    report.status = StepStatus::kInvalidMeasurement;
    return report;
  }
  const Vector<M> innovation = z - H * state.mean;
  return update_with_innovation(state, innovation, H, R);
}

/// Extended Kalman measurement update through a measurement model: linearizes h at the
/// prediction and forms the innovation with the model's residual (which wraps angles).
///
/// A measurement model provides kDim, predict(x), jacobian(x), residual(z, ẑ), covariance() and
/// defined_at(x); see position_measurement.hpp and polar_measurement.hpp.
template <int N, class Model>
UpdateReport<Model::kDim> update(GaussianState<N>& state, const Vector<Model::kDim>& z,
                                 const Model& model) {
  constexpr int M = Model::kDim;
  if (!z.allFinite()) {
    UpdateReport<M> report;
    report.status = StepStatus::kInvalidMeasurement;
    return report;
  }
  if (!model.defined_at(state.mean)) {
    UpdateReport<M> report;
    report.status = StepStatus::kUndefinedMeasurement;
    return report;
  }
  const Vector<M> innovation = model.residual(z, model.predict(state.mean));
  const Matrix<M, N> H = model.jacobian(state.mean);
  return update_with_innovation(state, innovation, H, model.covariance());
}

}  // namespace imm
