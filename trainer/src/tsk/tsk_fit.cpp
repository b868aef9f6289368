// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/tsk/tsk_fit.hpp"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/random.hpp"
#include "imm/models/learned/tsk_sensor_model.hpp"
#include "imm/trainer/parallel_for.hpp"

namespace imm::trainer::tsk {
namespace {

constexpr int kParametersPerRule = 7;

Eigen::MatrixXd design(const Eigen::MatrixXd& inputs) {
  Eigen::MatrixXd X(inputs.rows(), 3);
  X.col(0).setOnes();
  X.rightCols(2) = inputs;
  return X;
}

double weight_power(double u, double m) { return m == 2.0 ? u * u : std::pow(u, m); }

// Rules ↔ the parameter vector θ of the fine tuning.
std::vector<double> pack(const std::vector<TskRule>& rules) {
  std::vector<double> theta;
  theta.reserve(rules.size() * kParametersPerRule);
  for (const TskRule& r : rules) {
    theta.insert(theta.end(), {r.center(0), std::log(r.width(0)), r.center(1), std::log(r.width(1)),
                               r.consequent(0), r.consequent(1), r.consequent(2)});
  }
  return theta;
}

void unpack(const double* theta, std::vector<TskRule>& rules) {
  for (std::size_t r = 0; r < rules.size(); ++r) {
    const double* t = theta + r * kParametersPerRule;
    rules[r].center << t[0], t[2];
    rules[r].width << std::exp(t[1]), std::exp(t[3]);
    rules[r].consequent << t[4], t[5], t[6];
  }
}

// All residuals z_q − ẑ(x_q) and their Jacobian as one Ceres cost function.
class TskResiduals final : public ceres::CostFunction {
 public:
  TskResiduals(std::size_t rules, TNorm t_norm, const Eigen::MatrixXd& inputs,
               const Eigen::VectorXd& targets)
      : rules_(rules), t_norm_(t_norm), inputs_(inputs), targets_(targets) {
    set_num_residuals(static_cast<int>(targets.size()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(rules * kParametersPerRule));
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    std::vector<TskRule> rules(rules_);
    unpack(parameters[0], rules);
    const std::size_t p = rules_ * kParametersPerRule;
    std::vector<double> gradient(p);
    for (Eigen::Index q = 0; q < targets_.size(); ++q) {
      const Eigen::Vector2d x = inputs_.row(q).transpose();
      const bool want = jacobians != nullptr && jacobians[0] != nullptr;
      const double h =
          output_and_parameter_gradient(rules, t_norm_, x, want ? gradient.data() : nullptr);
      if (!std::isfinite(h)) return false;
      residuals[q] = targets_(q) - h;
      if (want) {
        double* row = jacobians[0] + static_cast<std::size_t>(q) * p;
        for (std::size_t i = 0; i < p; ++i) row[i] = -gradient[i];
      }
    }
    return true;
  }

 private:
  std::size_t rules_;
  TNorm t_norm_;
  const Eigen::MatrixXd& inputs_;
  const Eigen::VectorXd& targets_;
};

// The memberships of one sample from its c distances, into u (c entries). Allocation-free.
void memberships_into(const double* distances, Eigen::Index c, double fuzzifier, double* u) {
  Eigen::Index zeros = 0;
  double smallest = std::numeric_limits<double>::infinity();
  for (Eigen::Index r = 0; r < c; ++r) {
    zeros += distances[r] == 0.0 ? 1 : 0;
    smallest = std::min(smallest, distances[r]);
  }
  if (zeros > 0) {  // I_q ≠ ∅: the hyperplanes through the sample share it
    for (Eigen::Index r = 0; r < c; ++r) {
      u[r] = distances[r] == 0.0 ? 1.0 / static_cast<double>(zeros) : 0.0;
    }
    return;
  }
  // μʳ = 1 / Σ_s (dʳ/dˢ)^{2/(m−1)}, as w_r / Σ w with w_r = (d_min/d_r)^{2/(m−1)} ∈ (0, 1].
  const double exponent = 2.0 / (fuzzifier - 1.0);
  double sum = 0.0;
  for (Eigen::Index r = 0; r < c; ++r) {
    const double ratio = smallest / distances[r];
    u[r] = fuzzifier == 2.0 ? ratio * ratio : std::pow(ratio, exponent);
    sum += u[r];
  }
  for (Eigen::Index r = 0; r < c; ++r) u[r] /= sum;
}

}  // namespace

Eigen::VectorXd fcrm_memberships(const Eigen::VectorXd& distances, double fuzzifier) {
  Eigen::VectorXd u(distances.size());
  memberships_into(distances.data(), distances.size(), fuzzifier, u.data());
  return u;
}

FcrmResult fcrm_from(const Eigen::MatrixXd& inputs, const Eigen::VectorXd& targets,
                     const Eigen::MatrixXd& initial, const FcrmSettings& settings) {
  const Eigen::Index n = inputs.rows(), c = initial.cols();
  const Eigen::MatrixXd X = design(inputs);
  const double m = settings.fuzzifier;
  FcrmResult result;
  result.memberships = initial;
  result.hyperplanes.resize(c, 3);
  Eigen::MatrixXd distances(n, c), weighted(n, 3);
  Eigen::ArrayXXd next(n, c);
  for (int iteration = 1; iteration <= settings.max_iterations; ++iteration) {
    // Step 4: Pʳ by weighted least squares with weights (μʳ)^m: (Xᵀ W X) Pʳ = Xᵀ W z.
    for (Eigen::Index r = 0; r < c; ++r) {
      const Eigen::ArrayXd w = m == 2.0 ? result.memberships.col(r).array().square().eval()
                                        : result.memberships.col(r).array().pow(m).eval();
      weighted = X.array().colwise() * w;
      Eigen::Matrix3d A = weighted.transpose() * X;
      const Eigen::Vector3d b = weighted.transpose() * targets;
      A.diagonal().array() += 1e-12 * (1.0 + A.diagonal().array().abs());  // keeps A definite
      result.hyperplanes.row(r) = A.ldlt().solve(b).transpose();
    }
    // Step 2: distances and memberships; step 3: convergence.
    distances = ((X * result.hyperplanes.transpose()).colwise() - targets).cwiseAbs();
    // memberships_into for all samples at once (column-wise), then the I_q rows one by one.
    const Eigen::ArrayXd smallest = distances.rowwise().minCoeff();
    for (Eigen::Index r = 0; r < c; ++r) {
      const Eigen::ArrayXd ratio = smallest / distances.col(r).array();
      if (m == 2.0) {
        next.col(r) = ratio.square();
      } else {
        next.col(r) = ratio.pow(2.0 / (m - 1.0));
      }
    }
    next.colwise() /= next.rowwise().sum();
    for (Eigen::Index q = 0; q < n; ++q) {
      if (smallest(q) == 0.0) {
        Eigen::VectorXd d = distances.row(q).transpose(), u(c);
        memberships_into(d.data(), c, m, u.data());
        next.row(q) = u.transpose().array();
      }
    }
    const double change = (next.matrix() - result.memberships).cwiseAbs().maxCoeff();
    result.memberships = next.matrix();
    result.iterations = iteration;
    if (change <= settings.tolerance) {
      result.converged = true;
      break;
    }
  }
  result.objective = 0.0;
  for (Eigen::Index q = 0; q < n; ++q) {
    for (Eigen::Index r = 0; r < c; ++r) {
      result.objective +=
          weight_power(result.memberships(q, r), m) * distances(q, r) * distances(q, r);
    }
  }
  return result;
}

void FcrmSettings::validate() const {
  require(clusters >= 1 && clusters <= TskSensorModel::kMaxRules, "rules",
          "must be in [1, " + std::to_string(TskSensorModel::kMaxRules) + "]");
  require(fuzzifier >= 1.01 && fuzzifier <= 100.0, "fuzzifier", "must be in [1.01, 100]");
  require(tolerance >= 1e-15 && tolerance <= 1.0, "tolerance", "must be in [1e-15, 1]");
  require(max_iterations >= 1 && max_iterations <= 100000, "max_iterations",
          "must be in [1, 100000]");
  require(restarts >= 1 && restarts <= 1000, "restarts", "must be in [1, 1000]");
}

FcrmResult fcrm(const Eigen::MatrixXd& inputs, const Eigen::VectorXd& targets,
                const FcrmSettings& settings, std::uint64_t seed) {
  if (inputs.rows() != targets.size() || inputs.cols() != 2 || inputs.rows() < 3) {
    throw std::invalid_argument("fcrm: need N × 2 inputs and N targets, N ≥ 3");
  }
  settings.validate();
  // Restarts run in parallel; each depends only on (seed, start) and the lowest objective wins
  // (the earliest start on a tie), so the result does not depend on the thread count.
  std::vector<FcrmResult> results(static_cast<std::size_t>(settings.restarts));
  parallel_for(settings.restarts, 1, [&](long start) {
    // A start: each cluster's hyperplane fitted to the N/c samples nearest (in the input box
    // scaled to unit size) to a random sample — local planes, so that a piecewise-linear target
    // is split along its pieces — and the memberships of step 2 from those planes.
    datasets::Rng rng(datasets::derive_seed(seed, static_cast<std::uint64_t>(start)));
    const Eigen::Index n = inputs.rows();
    const Eigen::RowVector2d lo = inputs.colwise().minCoeff();
    const Eigen::RowVector2d span =
        (inputs.colwise().maxCoeff() - lo).cwiseMax(Eigen::RowVector2d::Constant(1e-12));
    const Eigen::MatrixXd scaled = (inputs.rowwise() - lo).array().rowwise() / span.array();
    const Eigen::MatrixXd X = design(inputs);
    const Eigen::Index local = std::max<Eigen::Index>(3, n / settings.clusters);
    Eigen::MatrixXd planes(settings.clusters, 3);
    std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
    for (int r = 0; r < settings.clusters; ++r) {
      const auto pick = static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(n)));
      const Eigen::VectorXd d2 = (scaled.rowwise() - scaled.row(pick)).rowwise().squaredNorm();
      for (Eigen::Index q = 0; q < n; ++q) order[static_cast<std::size_t>(q)] = q;
      std::nth_element(order.begin(), order.begin() + local - 1, order.end(),
                       [&](Eigen::Index a, Eigen::Index b) { return d2(a) < d2(b); });
      Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
      Eigen::Vector3d b = Eigen::Vector3d::Zero();
      for (Eigen::Index i = 0; i < local; ++i) {
        const Eigen::Index q = order[static_cast<std::size_t>(i)];
        A += X.row(q).transpose() * X.row(q);
        b += X.row(q).transpose() * targets(q);
      }
      A.diagonal().array() += 1e-12 * (1.0 + A.diagonal().array().abs());
      planes.row(r) = A.ldlt().solve(b).transpose();
    }
    const Eigen::MatrixXd distances = ((X * planes.transpose()).colwise() - targets).cwiseAbs();
    Eigen::MatrixXd initial(n, settings.clusters);
    for (Eigen::Index q = 0; q < n; ++q) {
      initial.row(q) =
          fcrm_memberships(distances.row(q).transpose(), settings.fuzzifier).transpose();
    }
    results[static_cast<std::size_t>(start)] = fcrm_from(inputs, targets, initial, settings);
  });
  FcrmResult best = std::move(results.front());
  for (std::size_t i = 1; i < results.size(); ++i) {
    if (results[i].objective < best.objective) best = std::move(results[i]);
  }
  best.restarts = settings.restarts;
  return best;
}

std::vector<TskRule> rules_from_clusters(const Eigen::MatrixXd& inputs, const FcrmResult& clusters,
                                         double fuzzifier) {
  const Eigen::Index c = clusters.hyperplanes.rows();
  const Eigen::Vector2d range = inputs.colwise().maxCoeff() - inputs.colwise().minCoeff();
  std::vector<TskRule> rules(static_cast<std::size_t>(c));
  for (Eigen::Index r = 0; r < c; ++r) {
    Eigen::VectorXd w(inputs.rows());
    for (Eigen::Index q = 0; q < inputs.rows(); ++q) {
      w(q) = weight_power(clusters.memberships(q, r), fuzzifier);
    }
    const double total = std::max(w.sum(), 1e-300);
    const Eigen::Vector2d mean = (inputs.transpose() * w) / total;
    const Eigen::Vector2d variance =
        ((inputs.rowwise() - mean.transpose()).array().square().colwise() * w.array())
            .colwise()
            .sum()
            .transpose() /
        total;
    TskRule& rule = rules[static_cast<std::size_t>(r)];
    rule.center = mean;
    rule.width = variance.cwiseSqrt().cwiseMax(1e-3 * range);
    rule.consequent = clusters.hyperplanes.row(r).transpose();
  }
  return rules;
}

Eigen::VectorXd predict(const std::vector<TskRule>& rules, TNorm t_norm,
                        const Eigen::MatrixXd& inputs) {
  Eigen::VectorXd out(inputs.rows());
  for (Eigen::Index q = 0; q < inputs.rows(); ++q) {
    out(q) = TskSensorModel::output(rules, t_norm, inputs.row(q).transpose());
  }
  return out;
}

double rmse(const std::vector<TskRule>& rules, TNorm t_norm, const Eigen::MatrixXd& inputs,
            const Eigen::VectorXd& targets) {
  return std::sqrt((predict(rules, t_norm, inputs) - targets).squaredNorm() /
                   static_cast<double>(std::max<Eigen::Index>(1, targets.size())));
}

double output_and_parameter_gradient(const std::vector<TskRule>& rules, TNorm t_norm,
                                     const Eigen::Vector2d& input, double* gradient) {
  if (rules.empty() || rules.size() > TskSensorModel::kMaxRules) {
    throw std::invalid_argument("TSK output: need 1 to " +
                                std::to_string(TskSensorModel::kMaxRules) + " rules");
  }
  const TskFiring f = TskSensorModel::fire(rules, t_norm, input);
  if (gradient) {
    for (std::size_t r = 0; r < f.rules; ++r) {
      const TskRule& rule = rules[r];
      double* g = gradient + r * kParametersPerRule;
      const double premise = f.share[r] * (f.rule_output[r] - f.value);  // ∂h/∂ log wʳ
      for (std::size_t s = 0; s < 2; ++s) {
        // ∂ log A/∂m = u/s, ∂ log A/∂ log s = u², u = (x − m)/s, for the inputs wʳ depends on.
        const auto i = static_cast<Eigen::Index>(s);
        const double u = f.scaled[r](i);
        g[2 * s] = premise * f.active[r](i) * u / rule.width(i);
        g[2 * s + 1] = premise * f.active[r](i) * u * u;
      }
      g[4] = f.share[r];
      g[5] = f.share[r] * input(0);
      g[6] = f.share[r] * input(1);
    }
  }
  return f.value;
}

FineTuningReport fine_tune(std::vector<TskRule>& rules, TNorm t_norm, const Eigen::MatrixXd& inputs,
                           const Eigen::VectorXd& targets, const FineTuning& settings) {
  std::vector<double> theta = pack(rules);
  ceres::Problem problem;
  problem.AddResidualBlock(new TskResiduals(rules.size(), t_norm, inputs, targets), nullptr,
                           theta.data());
  // Bounds that keep the premises meaningful: centers within one box width of the data, widths
  // between 10⁻³ and 10 box widths (a wider set is flat: that input no longer matters to the
  // rule, and 10 box widths already says so).
  const Eigen::Vector2d lo = inputs.colwise().minCoeff(), hi = inputs.colwise().maxCoeff();
  const Eigen::Vector2d span = (hi - lo).cwiseMax(Eigen::Vector2d::Constant(1e-9));
  for (std::size_t r = 0; r < rules.size(); ++r) {
    for (int d = 0; d < 2; ++d) {
      const int center = static_cast<int>(r) * kParametersPerRule + 2 * d;
      const auto at = static_cast<std::size_t>(center);
      theta[at] = std::clamp(theta[at], lo(d) - span(d), hi(d) + span(d));
      theta[at + 1] = std::clamp(theta[at + 1], std::log(1e-3 * span(d)), std::log(10.0 * span(d)));
      problem.SetParameterLowerBound(theta.data(), center, lo(d) - span(d));
      problem.SetParameterUpperBound(theta.data(), center, hi(d) + span(d));
      problem.SetParameterLowerBound(theta.data(), center + 1, std::log(1e-3 * span(d)));
      problem.SetParameterUpperBound(theta.data(), center + 1, std::log(10.0 * span(d)));
    }
  }
  ceres::Solver::Options options;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;  // 7c unknowns: a tiny normal matrix
  options.max_num_iterations = settings.max_iterations;
  options.function_tolerance = 1e-10;
  options.parameter_tolerance = 1e-10;
  options.num_threads = 1;  // deterministic
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  FineTuningReport report;
  report.iterations = static_cast<int>(summary.iterations.size());
  report.initial_cost = summary.initial_cost;
  report.final_cost = summary.final_cost;
  report.converged = summary.termination_type == ceres::CONVERGENCE;
  if (summary.final_cost <= summary.initial_cost && std::isfinite(summary.final_cost)) {
    unpack(theta.data(), rules);
  }
  return report;
}

}  // namespace imm::trainer::tsk
