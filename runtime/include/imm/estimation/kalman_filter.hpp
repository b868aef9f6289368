// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The Kalman algebra, written once: prediction, the Joseph-form measurement update, and the
/// extended (linearized) update through a measurement model. Every filter of the runtime — plain
/// KF, IMM mode, fuzzy-noise KF, EKF through a learned sensor model — calls these functions and
/// changes only what it feeds them (F, Q, the input, h and its Jacobian).
///
/// References: seed 000 eq. (7-1)–(7-7); the covariance update is the Joseph form
/// P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ, which stays symmetric positive semi-definite for any gain
/// and therefore survives extreme noise ratios where P − K S Kᵀ loses definiteness.

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <array>
#include <cmath>
#include <numbers>

#include "imm/core/physical_limits.hpp"
#include "imm/estimation/gaussian_state.hpp"
#include "imm/estimation/step_status.hpp"
#include "imm/math/linear_algebra.hpp"
#include "imm/math/log_sum_exp.hpp"

namespace imm {

/// What a measurement update reports besides the new state.
template <int M>
struct UpdateReport {
  /// kOk, or why the update was refused.
  StepStatus status = StepStatus::kOk;
  Vector<M> innovation = Vector<M>::Zero();  ///< ν = z − h(x̂⁻), wrapped if angular
  SquareMatrix<M> innovation_covariance = SquareMatrix<M>::Zero();  ///< S = H P⁻ Hᵀ + R
  double log_likelihood = 0.0;  ///< log N(ν; 0, S), seed 000 eq. (9) in log space

  /// Whether the update succeeded.
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
  symmetrize(predicted.covariance);
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
/// `selected`: when H is a selection (row i is 1 at column selected[i], 0 elsewhere), the
/// products with H are gathers of rows and columns — the same numbers (a sum whose other terms
/// are exact zeros), without the multiplications.
template <int N, int M>
UpdateReport<M> update_with_innovation(GaussianState<N>& state, const Vector<M>& innovation,
                                       const Matrix<M, N>& H, const SquareMatrix<M>& R,
                                       const std::array<int, std::size_t{M}>* selected = nullptr) {
  UpdateReport<M> report;
  report.innovation = innovation;
  Matrix<N, M> PHt;
  if (selected != nullptr) {
    for (int i = 0; i < M; ++i) {
      PHt.col(i) = state.covariance.col((*selected)[static_cast<std::size_t>(i)]);
    }
    for (int i = 0; i < M; ++i) {
      report.innovation_covariance.row(i) = PHt.row((*selected)[static_cast<std::size_t>(i)]);
    }
  } else {
    PHt.noalias() = state.covariance * H.transpose();
    report.innovation_covariance.noalias() = H * PHt;
  }
  report.innovation_covariance += R;
  symmetrize(report.innovation_covariance);
  const SquareMatrix<M>& S = report.innovation_covariance;
  if (!S.allFinite()) {
    report.status = StepStatus::kSingularInnovation;
    return report;
  }

  // Positive definiteness and log|S|: closed forms for the common M ≤ 2 (Sylvester's criterion),
  // a Cholesky factorization otherwise.
  double log_det = 0.0;
  if constexpr (M == 1) {
    if (!(S(0, 0) > 0.0)) {
      report.status = StepStatus::kSingularInnovation;
      return report;
    }
    log_det = std::log(S(0, 0));
  } else if constexpr (M == 2) {
    const double det = S(0, 0) * S(1, 1) - S(0, 1) * S(1, 0);
    // The relative guard rejects S whose determinant is lost in cancellation.
    if (!(S(0, 0) > 0.0) || !(det > 1e-14 * S(0, 0) * S(1, 1))) {
      report.status = StepStatus::kSingularInnovation;
      return report;
    }
    log_det = std::log(det);
  } else {
    const Eigen::LLT<SquareMatrix<M>> llt(S);
    if (llt.info() != Eigen::Success) {
      report.status = StepStatus::kSingularInnovation;
      return report;
    }
    const SquareMatrix<M> L = llt.matrixL();
    for (int i = 0; i < M; ++i) {
      if (!(L(i, i) > 0.0)) {
        report.status = StepStatus::kSingularInnovation;
        return report;
      }
      log_det += 2.0 * std::log(L(i, i));
    }
  }

  // K = P Hᵀ S⁻¹. S is positive definite (checked above); for the small measurement dimensions of
  // tracking (M ≤ 4) Eigen inverts fixed-size matrices in closed form, which is as accurate as the
  // triangular solves here and several times faster.
  SquareMatrix<M> S_inverse;
  if constexpr (M <= 4) {
    S_inverse = S.inverse();
  } else {
    S_inverse = S.llt().solve(SquareMatrix<M>::Identity());
  }
  symmetrize(S_inverse);
  Matrix<N, M> K;
  K.noalias() = PHt * S_inverse;

  // Joseph form (I − KH) P (I − KH)ᵀ + K R Kᵀ, evaluated without forming I − KH:
  // C = (I − KH) P = P − K (P Hᵀ)ᵀ, then C (I − KH)ᵀ = C − (C Hᵀ) Kᵀ.
  SquareMatrix<N> C = state.covariance;
  C.noalias() -= K * PHt.transpose();
  Matrix<N, M> CHt;
  if (selected != nullptr) {
    for (int i = 0; i < M; ++i) CHt.col(i) = C.col((*selected)[static_cast<std::size_t>(i)]);
  } else {
    CHt.noalias() = C * H.transpose();
  }
  Matrix<N, M> KR;
  KR.noalias() = K * R;
  GaussianState<N> updated;
  updated.mean = state.mean;
  updated.mean.noalias() += K * innovation;
  updated.covariance = C;
  updated.covariance.noalias() -= CHt * K.transpose();
  updated.covariance.noalias() += KR * K.transpose();
  symmetrize(updated.covariance);
  if (!updated.usable()) {
    report.status = StepStatus::kNonFiniteResult;
    return report;
  }

  const double mahalanobis = innovation.dot(S_inverse * innovation);
  report.log_likelihood = -0.5 * (mahalanobis + log_det + M * kLogTwoPi);
  state = updated;
  return report;
}

/// Measurement update with a given (not necessarily optimal) gain K:
///   x⁺ = x⁻ + K ν,  P⁺ = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ,
/// the Joseph form, which is the exact error covariance of this update for any gain (not only
/// the Kalman gain) and stays positive semi-definite. The log-likelihood is that of ν under the
/// nominal S = H P⁻ Hᵀ + R. On any status other than kOk `state` is left as it was.
template <int N, int M>
UpdateReport<M> update_with_gain(GaussianState<N>& state, const Vector<M>& innovation,
                                 const Matrix<M, N>& H, const SquareMatrix<M>& R,
                                 const Matrix<N, M>& K) {
  UpdateReport<M> report;
  report.innovation = innovation;
  report.innovation_covariance.noalias() = H * state.covariance * H.transpose();
  report.innovation_covariance += R;
  symmetrize(report.innovation_covariance);
  // S = L Lᵀ: for one measurement L = √S, written out (what Eigen's LLT computes for a 1 × 1
  // matrix, without its norm and solve machinery).
  SquareMatrix<M> L;
  bool factored = false;
  if constexpr (M == 1) {
    factored = report.innovation_covariance(0, 0) > 0.0;
    L(0, 0) = std::sqrt(report.innovation_covariance(0, 0));
  } else {
    const Eigen::LLT<SquareMatrix<M>> llt(report.innovation_covariance);
    factored = llt.info() == Eigen::Success;
    L = llt.matrixL();
  }
  if (!report.innovation_covariance.allFinite() || !factored || !K.allFinite()) {
    report.status = StepStatus::kSingularInnovation;
    return report;
  }
  SquareMatrix<N> A = SquareMatrix<N>::Identity();
  A.noalias() -= K * H;
  GaussianState<N> updated;
  updated.mean = state.mean;
  updated.mean.noalias() += K * innovation;
  updated.covariance.noalias() = A * state.covariance * A.transpose();
  updated.covariance.noalias() += K * R * K.transpose();
  symmetrize(updated.covariance);
  if (!updated.usable()) {
    report.status = StepStatus::kNonFiniteResult;
    return report;
  }
  Vector<M> whitened;
  if constexpr (M == 1) {
    whitened(0) = innovation(0) / L(0, 0);
  } else {
    whitened = L.template triangularView<Eigen::Lower>().solve(innovation);
  }
  double log_det = 0.0;
  for (int i = 0; i < M; ++i) log_det += 2.0 * std::log(L(i, i));
  report.log_likelihood = -0.5 * (whitened.squaredNorm() + log_det + M * kLogTwoPi);
  state = updated;
  return report;
}

/// Linear Kalman measurement update, z = H x + v, v ~ N(0, R) (seed 000 eq. 7-3–7-7).
template <int N, int M>
UpdateReport<M> update(GaussianState<N>& state, const Vector<M>& z, const Matrix<M, N>& H,
                       const SquareMatrix<M>& R) {
  if (!limits::usable_measurement(z)) {
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
  if (!limits::usable_measurement(z)) {
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
  const Matrix<M, N>& H = model.jacobian(state.mean);  // a reference or an extended temporary
  if constexpr (requires { model.selected_indices(); }) {
    return update_with_innovation(state, innovation, H, model.covariance(),
                                  &model.selected_indices());
  } else {
    return update_with_innovation(state, innovation, H, model.covariance());
  }
}

/// The predicted plot ẑ = h(x⁻) of a prediction and its covariance S = H P⁻ Hᵀ + R; false, and
/// nothing written, where h is undefined there.
template <int N, class Model>
bool predict_plot(const GaussianState<N>& predicted, const Model& model, Vector<Model::kDim>& z_hat,
                  SquareMatrix<Model::kDim>& S) {
  if (!model.defined_at(predicted.mean)) return false;
  const Matrix<Model::kDim, N>& H = model.jacobian(predicted.mean);
  z_hat = model.predict(predicted.mean);
  S = H * predicted.covariance * H.transpose() + model.covariance();
  return true;
}

/// The innovation ν = z − h(x⁻) of a candidate plot (wrapped by the model's residual) and S, as
/// update() would form them; false, and nothing written, for an unusable plot or an undefined h.
template <int N, class Model>
bool score_candidate(const GaussianState<N>& predicted, const Vector<Model::kDim>& z,
                     const Model& model, Vector<Model::kDim>& nu, SquareMatrix<Model::kDim>& S) {
  if (!limits::usable_measurement(z)) return false;
  Vector<Model::kDim> z_hat;
  if (!predict_plot(predicted, model, z_hat, S)) return false;
  nu = model.residual(z, z_hat);
  return true;
}

/// predict_plot() of a linear measurement z = H x + v, v ~ N(0, R); false where ẑ or S is not
/// finite.
template <int N, int M>
bool predict_plot(const GaussianState<N>& predicted, const Matrix<M, N>& H,
                  const SquareMatrix<M>& R, Vector<M>& z_hat, SquareMatrix<M>& S) {
  z_hat = H * predicted.mean;
  S = H * predicted.covariance * H.transpose() + R;
  return z_hat.allFinite() && S.allFinite();
}

/// score_candidate() of a linear measurement (see predict_plot above): ν = z − H x⁻.
template <int N, int M>
bool score_candidate(const GaussianState<N>& predicted, const Vector<M>& z, const Matrix<M, N>& H,
                     const SquareMatrix<M>& R, Vector<M>& nu, SquareMatrix<M>& S) {
  if (!limits::usable_measurement(z)) return false;
  Vector<M> z_hat;
  if (!predict_plot(predicted, H, R, z_hat, S)) return false;
  nu = z - z_hat;
  return true;
}

/// The default step tolerance of iterated_update, relative to the prior's standard deviations.
inline constexpr double kIteratedUpdateTolerance = 1e-6;

/// Iterated extended Kalman update (Gauss–Newton on the MAP objective; Bell & Cathey): starting
/// at x₀ = x⁻, each iteration linearizes h at x_i and updates the prior with
///   ν_i = z − h(x_i) − H_i (x⁻ − x_i),  x_{i+1} = x⁻ + K_i ν_i,  K_i from H_i,
/// stopping after `iterations` linearizations or when the step is below `tolerance` (relative to
/// the prior's standard deviations). The covariance (Joseph form) and the log-likelihood
/// N(ν_i; 0, S_i) are those of the last linearization. iterations = 1 is the EKF update. Where h
/// saturates, the prediction may sit on the flat part and the EKF barely moves; relinearizing at
/// the updated estimate recovers the slope the measurement actually saw.
template <int N, class Model>
UpdateReport<Model::kDim> iterated_update(GaussianState<N>& state, const Vector<Model::kDim>& z,
                                          const Model& model, int iterations,
                                          double tolerance = kIteratedUpdateTolerance) {
  if (iterations <= 1) return update(state, z, model);
  constexpr int M = Model::kDim;
  if (!limits::usable_measurement(z)) {
    UpdateReport<M> report;
    report.status = StepStatus::kInvalidMeasurement;
    return report;
  }
  const GaussianState<N> prior = state;
  const Vector<N> scale = prior.covariance.diagonal().cwiseSqrt().cwiseMax(1e-300);
  Vector<N> point = prior.mean;
  UpdateReport<M> report;
  GaussianState<N> candidate;
  for (int i = 0; i < iterations; ++i) {
    if (!model.defined_at(point)) {
      report = UpdateReport<M>{};
      report.status = StepStatus::kUndefinedMeasurement;
      return report;
    }
    const Matrix<M, N>& H = model.jacobian(point);  // a reference or an extended temporary
    const Vector<M> innovation = model.residual(z, model.predict(point)) - H * (prior.mean - point);
    candidate = prior;
    report = update_with_innovation(candidate, innovation, H, model.covariance());
    if (!report.ok()) return report;
    const double step = ((candidate.mean - point).array() / scale.array()).abs().maxCoeff();
    point = candidate.mean;
    if (step < tolerance) break;
  }
  state = candidate;
  return report;
}

}  // namespace imm
