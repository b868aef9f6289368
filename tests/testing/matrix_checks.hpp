// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Shared checkers for the test suite: matrix closeness, symmetric positive definiteness and
/// Jacobians against central finite differences.

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <bit>
#include <cstdint>
#include <sstream>

namespace imm::testing {

/// Whether two doubles have the same bits (−0 and +0 differ, a NaN equals only its own bits).
[[nodiscard]] inline bool same_bits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

/// |a − b| ≤ tolerance · max(1, |b|) entry-wise.
template <class A, class B>
::testing::AssertionResult matrices_near(const Eigen::MatrixBase<A>& a,
                                         const Eigen::MatrixBase<B>& b, double tolerance) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) {
    return ::testing::AssertionFailure()
           << "shape " << a.rows() << "x" << a.cols() << " vs " << b.rows() << "x" << b.cols();
  }
  for (Eigen::Index i = 0; i < a.rows(); ++i) {
    for (Eigen::Index j = 0; j < a.cols(); ++j) {
      const double scale = std::max(1.0, std::abs(b(i, j)));
      if (!(std::abs(a(i, j) - b(i, j)) <= tolerance * scale)) {
        std::ostringstream out;
        out << "entry (" << i << ", " << j << "): " << a(i, j) << " vs " << b(i, j)
            << " (tolerance " << tolerance << ")\nfirst:\n"
            << a << "\nsecond:\n"
            << b;
        return ::testing::AssertionFailure() << out.str();
      }
    }
  }
  return ::testing::AssertionSuccess();
}

/// Symmetric to rounding and strictly positive definite (Cholesky succeeds, λ_min > 0).
template <class A>
::testing::AssertionResult symmetric_positive_definite(const Eigen::MatrixBase<A>& m) {
  const Eigen::MatrixXd p = m;
  if (!p.allFinite()) return ::testing::AssertionFailure() << "non-finite entries\n" << p;
  const double asymmetry = (p - p.transpose()).cwiseAbs().maxCoeff();
  if (asymmetry > 1e-12 * std::max(1.0, p.cwiseAbs().maxCoeff())) {
    return ::testing::AssertionFailure() << "asymmetric by " << asymmetry << "\n" << p;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(p);
  if (eigen.eigenvalues().minCoeff() <= 0.0 ||
      Eigen::LLT<Eigen::MatrixXd>(p).info() != Eigen::Success) {
    return ::testing::AssertionFailure()
           << "not positive definite, eigenvalues " << eigen.eigenvalues().transpose();
  }
  return ::testing::AssertionSuccess();
}

/// Central-difference Jacobian of f: R^N → R^M at x with step h·max(1, |x_i|).
template <int M, int N, class F>
Eigen::Matrix<double, M, N> finite_difference_jacobian(F&& f, const Eigen::Matrix<double, N, 1>& x,
                                                       double h = 1e-6) {
  Eigen::Matrix<double, M, N> J;
  for (int i = 0; i < N; ++i) {
    const double step = h * std::max(1.0, std::abs(x(i)));
    Eigen::Matrix<double, N, 1> plus = x, minus = x;
    plus(i) += step;
    minus(i) -= step;
    J.col(i) = (f(plus) - f(minus)) / (2.0 * step);
  }
  return J;
}

}  // namespace imm::testing
