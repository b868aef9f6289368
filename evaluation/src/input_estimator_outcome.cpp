// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/input_estimator_outcome.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>

#include "imm/datasets/axis_trajectory.hpp"
#include "imm/estimation/kalman_filter.hpp"
#include "imm/evaluation/experiment.hpp"
#include "imm/trainer/ranks.hpp"

namespace imm::evaluation {
namespace {

constexpr double kNotANumber = std::numeric_limits<double>::quiet_NaN();

// Axis runs × scans of one consistency series.
Eigen::MatrixXd stacked(const std::vector<Eigen::RowVectorXd>& rows) {
  Eigen::MatrixXd values(static_cast<Eigen::Index>(rows.size()),
                         rows.empty() ? 0 : rows.front().size());
  for (std::size_t j = 0; j < rows.size(); ++j) values.row(static_cast<Eigen::Index>(j)) = rows[j];
  return values;
}

}  // namespace

std::vector<InputEstimatorCase> run_input_estimator_cases(const MlpInputEstimatorModel& model,
                                                          const AxisCvImmSpec& imm_tuned,
                                                          const datasets::Regime& regime,
                                                          const datasets::TrackSet& data) {
  const CvKfSettings& settings = model.settings;
  const double T = settings.sample_period;
  const double R = settings.measurement_variance;
  const auto motion = constant_velocity<1>(T, settings.process_noise);
  const Matrix<2, 1> G = cv_axis_input_gain(T);
  Matrix<1, 2> H;
  H << 1.0, 0.0;
  const SquareMatrix<1> R_matrix = SquareMatrix<1>::Constant(R);
  const int steps = data.scans;
  std::vector<InputEstimatorCase> cases(static_cast<std::size_t>(regime.case_count()));
  std::vector<std::vector<Eigen::RowVector3d>> cv_runs(cases.size()), corrected_runs(cases.size()),
      floor_runs(cases.size()), imm_runs(cases.size());
  std::vector<int> case_runs(cases.size(), 0);
  std::vector<std::array<std::vector<Eigen::RowVectorXd>, 4>> consistency_rows(cases.size());
  for (std::size_t c = 0; c < cases.size(); ++c) {
    cases[c].name = case_label(regime, static_cast<int>(c));
    cases[c].mean_estimate = Eigen::VectorXd::Zero(steps);
    cases[c].cv_position_rmse = Eigen::VectorXd::Zero(steps);
    cases[c].corrected_position_rmse = Eigen::VectorXd::Zero(steps);
  }
  // axis_trajectories gives each track's x then its y axis.
  const std::vector<datasets::AxisTrajectory> axes = datasets::axis_trajectories(data);
  // One axis run's terms: its mean squared innovation, position and velocity errors of the CV
  // filter, the corrected estimate, the known-input floor and IMM-tuned (4 × 3); per scan:
  // counted, the acceleration estimate, the CV and corrected squared position errors, then the
  // position NEES and the NIS of the corrected KF and of IMM-tuned (NaN where a filter rejected
  // the plot: each filter's figures are over the plots it used).
  constexpr std::ptrdiff_t kPerScan = 8;
  constexpr std::ptrdiff_t kRunTerms = 12;
  const auto width = static_cast<int>(kRunTerms + steps * kPerScan);
  const std::vector<double> all = trainer::shared_items(
      static_cast<long>(axes.size()), width, [&](long run, std::span<double> terms) {
        const datasets::AxisTrajectory& t = axes[static_cast<std::size_t>(run)];
        MlpInputEstimatorAxis axis(model, settings);
        ImmAxisFilter imm(build_axis_cv_imm(imm_tuned));
        const GaussianState<2> start = datasets::two_point_start(t, T, R);
        axis.initialize(start);
        imm.initialize(start);
        GaussianState<2> known = start;  // the primary KF fed the true acceleration
        Eigen::RowVector3d cv = Eigen::RowVector3d::Zero(), corrected = cv, floor = cv, tuned = cv;
        int samples = 0, imm_samples = 0;
        auto add = [](Eigen::RowVector3d& sum, double nu, double dp, double dv) {
          sum += Eigen::RowVector3d(nu * nu, dp * dp, dv * dv);
        };
        // ν²/S and the position's e²/P (1-D NIS and NEES).
        auto consistency = [&t](double* out, const AxisFilter& scored, int k) {
          const GaussianState<2>& x = scored.estimate();
          out[0] = x.covariance(0, 0) > 0.0
                       ? std::pow(t.position(k) - x.mean(0), 2) / x.covariance(0, 0)
                       : kNotANumber;
          double nu = 0.0, variance = 0.0;
          out[1] =
              scored.innovation(nu, variance) && variance > 0.0 ? nu * nu / variance : kNotANumber;
        };
        for (int k = 2; k < steps; ++k) {
          double* scan = terms.data() + kRunTerms + k * kPerScan;
          std::fill_n(scan + 4, 4, kNotANumber);
          if (imm.step(t.measurement(k)) == StepStatus::kOk) {
            const auto& m = imm.estimate();
            add(tuned, 0.0, t.position(k) - m.mean(0), t.velocity(k) - m.mean(1));
            ++imm_samples;
            consistency(scan + 6, imm, k);
          }
          if (axis.step(t.measurement(k)) != StepStatus::kOk) continue;
          known = predict(known, motion.transition, motion.process_noise, G,
                          Vector<1>(t.acceleration_input(k - 1)));
          const auto known_report = update(known, Vector<1>(t.measurement(k)), H, R_matrix);
          const MlpInputEstimatorFilter& filter = axis.filter();
          const auto& e = filter.cv_estimate();
          const auto& p = filter.estimate();
          add(cv, filter.cv_innovation(), t.position(k) - e.mean(0), t.velocity(k) - e.mean(1));
          add(corrected, filter.innovation(), t.position(k) - p.mean(0), t.velocity(k) - p.mean(1));
          add(floor, known_report.innovation(0), t.position(k) - known.mean(0),
              t.velocity(k) - known.mean(1));
          ++samples;
          scan[0] = 1.0;
          scan[1] = filter.acceleration();
          scan[2] = std::pow(t.position(k) - e.mean(0), 2);
          scan[3] = std::pow(t.position(k) - p.mean(0), 2);
          consistency(scan + 4, axis, k);
        }
        const double n = std::max(1, samples);
        Eigen::Map<Eigen::RowVector3d>(terms.data()) = cv / n;
        Eigen::Map<Eigen::RowVector3d>(terms.data() + 3) = corrected / n;
        Eigen::Map<Eigen::RowVector3d>(terms.data() + 6) = floor / n;
        Eigen::Map<Eigen::RowVector3d>(terms.data() + 9) = tuned / std::max(1, imm_samples);
      });
  // The figures, summed in run order.
  for (std::size_t run = 0; run < axes.size(); ++run) {
    const datasets::AxisTrajectory& t = axes[run];
    const auto c = static_cast<std::size_t>(data.tracks[run / 2].case_index);
    InputEstimatorCase& out = cases[c];
    if (case_runs[c] == 0) out.true_acceleration = t.acceleration_input;
    ++case_runs[c];
    const double* terms = all.data() + static_cast<std::ptrdiff_t>(run) * width;
    auto& rows = consistency_rows[c];
    for (auto& series : rows) series.emplace_back(Eigen::RowVectorXd::Constant(steps, kNotANumber));
    for (int k = 2; k < steps; ++k) {
      const double* scan = terms + kRunTerms + k * kPerScan;
      for (std::size_t i = 0; i < 4; ++i) rows[i].back()(k) = scan[4 + i];
      if (scan[0] == 0.0) continue;
      out.mean_estimate(k) += scan[1];
      out.cv_position_rmse(k) += scan[2];
      out.corrected_position_rmse(k) += scan[3];
    }
    cv_runs[c].emplace_back(Eigen::Map<const Eigen::RowVector3d>(terms));
    corrected_runs[c].emplace_back(Eigen::Map<const Eigen::RowVector3d>(terms + 3));
    floor_runs[c].emplace_back(Eigen::Map<const Eigen::RowVector3d>(terms + 6));
    imm_runs[c].emplace_back(Eigen::Map<const Eigen::RowVector3d>(terms + 9));
  }
  auto stack = [](const std::vector<Eigen::RowVector3d>& rows) {
    Eigen::MatrixXd m(static_cast<Eigen::Index>(rows.size()), 3);
    for (std::size_t i = 0; i < rows.size(); ++i) m.row(static_cast<Eigen::Index>(i)) = rows[i];
    return m;
  };
  for (std::size_t c = 0; c < cases.size(); ++c) {
    cases[c].cv = stack(cv_runs[c]);
    cases[c].corrected = stack(corrected_runs[c]);
    cases[c].floor = stack(floor_runs[c]);
    cases[c].imm = stack(imm_runs[c]);
    const double n = std::max(1, case_runs[c]);
    cases[c].mean_estimate /= n;
    cases[c].cv_position_rmse = (cases[c].cv_position_rmse / n).cwiseSqrt();
    cases[c].corrected_position_rmse = (cases[c].corrected_position_rmse / n).cwiseSqrt();
    for (std::size_t i = 0; i < 4; ++i) cases[c].consistency[i] = stacked(consistency_rows[c][i]);
  }

  return cases;
}

}  // namespace imm::evaluation
