// SPDX-License-Identifier: Apache-2.0
#pragma once
/// A deliberately plain IMM written from the textbook (Bar-Shalom, Li & Kirubarajan §11.6.6):
/// dynamic-size matrices, linear-space probabilities, the standard covariance update
/// P = (I − K H) P⁻, explicit inverses — no shortcut the runtime takes. The runtime's IMM is
/// tested against it. Modes of lower dimension are zero-padded into the mixing space through a
/// selection matrix E (x_mix = E x_mode), exactly as the IMM description says.

#include <Eigen/Dense>
#include <cmath>
#include <numbers>
#include <vector>

namespace imm::testing {

struct TextbookMode {
  Eigen::MatrixXd E;  ///< nx_mix × n selection (embedding) matrix
  Eigen::MatrixXd F, Q, H, R;
  Eigen::VectorXd x;  ///< mode estimate (own dimension)
  Eigen::MatrixXd P;
};

class TextbookImm {
 public:
  TextbookImm(std::vector<TextbookMode> modes, Eigen::MatrixXd transition, Eigen::VectorXd mu)
      : modes_(std::move(modes)), pi_(std::move(transition)), mu_(std::move(mu)) {}

  void step(const Eigen::VectorXd& z) {
    const int r = static_cast<int>(modes_.size());
    // Predicted mode probabilities and mixing probabilities.
    Eigen::VectorXd c = Eigen::VectorXd::Zero(r);
    for (int j = 0; j < r; ++j)
      for (int i = 0; i < r; ++i) c(j) += pi_(i, j) * mu_(i);
    Eigen::MatrixXd w(r, r);
    for (int i = 0; i < r; ++i)
      for (int j = 0; j < r; ++j) w(i, j) = pi_(i, j) * mu_(i) / c(j);
    // Mixing in the common space.
    std::vector<Eigen::VectorXd> xs;
    std::vector<Eigen::MatrixXd> ps;
    for (const auto& m : modes_) {
      xs.push_back(m.E * m.x);
      ps.push_back(m.E * m.P * m.E.transpose());
    }
    std::vector<Eigen::VectorXd> x0(static_cast<std::size_t>(r));
    std::vector<Eigen::MatrixXd> p0(static_cast<std::size_t>(r));
    for (int j = 0; j < r; ++j) {
      Eigen::VectorXd xm = Eigen::VectorXd::Zero(xs[0].size());
      for (int i = 0; i < r; ++i) xm += w(i, j) * xs[static_cast<std::size_t>(i)];
      Eigen::MatrixXd pm = Eigen::MatrixXd::Zero(xm.size(), xm.size());
      for (int i = 0; i < r; ++i) {
        const Eigen::VectorXd d = xs[static_cast<std::size_t>(i)] - xm;
        pm += w(i, j) * (ps[static_cast<std::size_t>(i)] + d * d.transpose());
      }
      x0[static_cast<std::size_t>(j)] = xm;
      p0[static_cast<std::size_t>(j)] = pm;
    }
    // Mode-matched filtering; the predicted measurement density Σ_j c_j N(ẑ_j, S_j) is kept by its
    // first two moments.
    Eigen::VectorXd likelihood(r);
    std::vector<Eigen::VectorXd> z_hat(static_cast<std::size_t>(r));
    std::vector<Eigen::MatrixXd> s_mode(static_cast<std::size_t>(r));
    for (int j = 0; j < r; ++j) {
      auto& m = modes_[static_cast<std::size_t>(j)];
      const Eigen::VectorXd x = m.E.transpose() * x0[static_cast<std::size_t>(j)];
      const Eigen::MatrixXd P = m.E.transpose() * p0[static_cast<std::size_t>(j)] * m.E;
      const Eigen::VectorXd xp = m.F * x;
      const Eigen::MatrixXd Pp = m.F * P * m.F.transpose() + m.Q;
      const Eigen::VectorXd nu = z - m.H * xp;
      const Eigen::MatrixXd S = m.H * Pp * m.H.transpose() + m.R;
      z_hat[static_cast<std::size_t>(j)] = m.H * xp;
      s_mode[static_cast<std::size_t>(j)] = S;
      const Eigen::MatrixXd K = Pp * m.H.transpose() * S.inverse();
      m.x = xp + K * nu;
      const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(xp.size(), xp.size());
      m.P = (I - K * m.H) * Pp;
      const double quad = nu.dot(S.inverse() * nu);
      likelihood(j) = std::exp(-0.5 * quad) /
                      std::sqrt(std::pow(2.0 * std::numbers::pi, static_cast<double>(z.size())) *
                                S.determinant());
    }
    const Eigen::VectorXd unnormalized = likelihood.cwiseProduct(c);
    predictive_likelihood_ = unnormalized.sum();
    mu_ = unnormalized / unnormalized.sum();
    Eigen::VectorXd predicted = Eigen::VectorXd::Zero(z.size());
    for (int j = 0; j < r; ++j) predicted += c(j) * z_hat[static_cast<std::size_t>(j)];
    innovation_covariance_ = Eigen::MatrixXd::Zero(z.size(), z.size());
    for (int j = 0; j < r; ++j) {
      const Eigen::VectorXd d = z_hat[static_cast<std::size_t>(j)] - predicted;
      innovation_covariance_ += c(j) * (s_mode[static_cast<std::size_t>(j)] + d * d.transpose());
    }
    innovation_ = z - predicted;
  }

  /// p(z | Z^(k−1)) of the last plot: Σ_j c_j N(ν_j; 0, S_j), in linear space.
  [[nodiscard]] double predictive_likelihood() const { return predictive_likelihood_; }
  /// The last step's z − ẑ and the covariance of the predicted measurement density.
  [[nodiscard]] const Eigen::VectorXd& innovation() const { return innovation_; }
  [[nodiscard]] const Eigen::MatrixXd& innovation_covariance() const {
    return innovation_covariance_;
  }

  [[nodiscard]] Eigen::VectorXd mean() const {
    Eigen::VectorXd x = Eigen::VectorXd::Zero(modes_[0].E.rows());
    for (std::size_t j = 0; j < modes_.size(); ++j)
      x += mu_(static_cast<Eigen::Index>(j)) * (modes_[j].E * modes_[j].x);
    return x;
  }

  [[nodiscard]] Eigen::MatrixXd covariance() const {
    const Eigen::VectorXd x = mean();
    Eigen::MatrixXd P = Eigen::MatrixXd::Zero(x.size(), x.size());
    for (std::size_t j = 0; j < modes_.size(); ++j) {
      const auto& m = modes_[j];
      const Eigen::VectorXd d = m.E * m.x - x;
      P += mu_(static_cast<Eigen::Index>(j)) * (m.E * m.P * m.E.transpose() + d * d.transpose());
    }
    return P;
  }

  [[nodiscard]] const Eigen::VectorXd& probabilities() const { return mu_; }

 private:
  std::vector<TextbookMode> modes_;
  Eigen::MatrixXd pi_;
  Eigen::VectorXd mu_;
  Eigen::VectorXd innovation_;
  Eigen::MatrixXd innovation_covariance_;
  double predictive_likelihood_ = 0.0;
};

}  // namespace imm::testing
