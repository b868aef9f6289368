// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// A 2-D filter as a track sees it (tracker.hpp): a plain IMM, two per-axis IMMs, an adaptive IMM.
/// State layout: one block per axis, [x, vx, y, vy] or [x, vx, ax, y, vy, ay].

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "imm/estimation/step_status.hpp"
#include "imm/math/linear_algebra.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// The names of a track state's entries: [x, vx, y, vy] (4), [x, vx, ax, y, vy, ay] (6), and a
/// coordinated-turn mode's turn rate "omega" last when the dimension is odd (5, 7).
[[nodiscard]] inline std::vector<std::string> state_variable_names(int dimension) {
  std::vector<std::string> names = {"x", "vx", "y", "vy"};
  if (dimension >= 6) names = {"x", "vx", "ax", "y", "vy", "ay"};
  if (dimension % 2 == 1) names.emplace_back("omega");
  return names;
}

/// The check every TrackFilter::initialize makes before it touches its state: throws
/// InvalidParameter("initial_state") for a mean that is not `dimension` finite numbers,
/// ("initial_covariance") for a covariance that is not `dimension` × `dimension`, finite and
/// symmetric with a non-negative diagonal.
IMM_RUNTIME_EXPORT void require_initial_state(const Eigen::VectorXd& mean,
                                              const Eigen::MatrixXd& covariance, int dimension);

/// A filter that tracks one target in two dimensions: what Tracker drives and load_filter returns,
/// for every model kind.
class IMM_RUNTIME_EXPORT TrackFilter {
 public:
  TrackFilter() = default;
  TrackFilter(const TrackFilter&) = delete;
  TrackFilter& operator=(const TrackFilter&) = delete;
  virtual ~TrackFilter() = default;

  /// The length of the state (4 to 7: state_variable_names).
  [[nodiscard]] virtual int state_dimension() const = 0;
  /// The number of modes (1 for a single-model filter).
  [[nodiscard]] virtual int mode_count() const = 0;
  /// The name of mode j (0-based).
  [[nodiscard]] virtual std::string mode_name(int j) const = 0;

  /// Starts the filter from a Gaussian in its layout (state_dimension() entries). Throws
  /// InvalidParameter as require_initial_state does, and changes nothing then.
  virtual void initialize(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) = 0;
  /// One cycle with plot z; any status other than kOk means z was not used.
  virtual StepStatus step(const Eigen::Vector2d& z) = 0;
  /// One cycle without a plot.
  virtual StepStatus predict_only() = 0;

  /// Combined mean and covariance diagonal.
  virtual void state(Eigen::Ref<Eigen::VectorXd> mean,
                     Eigen::Ref<Eigen::VectorXd> variance) const = 0;
  /// The combined covariance, state_dimension() square (the NEES of an evaluation needs its
  /// off-diagonal terms).
  virtual void covariance(Eigen::Ref<Eigen::MatrixXd> covariance) const = 0;
  /// The mode probabilities, in mode order.
  [[nodiscard]] virtual ModeVector mode_probabilities() const = 0;
  /// The last cycle's innovation ν = z − ẑ and its covariance S in the coordinates the filter
  /// updated in (Cartesian [x, y], or [range, azimuth] for polar plots, as the family states),
  /// combined over the modes (ImmEstimator::innovation): νᵀ S⁻¹ ν is the normalized innovation
  /// squared of a consistency check. False, and nothing written, unless the last call was a
  /// successful step().
  virtual bool innovation(Eigen::Vector2d& nu, Eigen::Matrix2d& S) const = 0;
  /// log p(z | Z^(k−1)) of the last step's plot under the filter's predicted measurement density:
  /// for an IMM the mixture log Σ_j c_j N(ν_j; 0, S_j) (ImmEstimator::log_predictive_likelihood),
  /// for a single model log N(ν; 0, S). What training from plots alone maximizes and the
  /// evaluation on recorded plots reports. NaN unless the last call was a successful step(). The
  /// default is the Gaussian of innovation(); every IMM family overrides it with its mixture.
  [[nodiscard]] virtual double log_predictive_likelihood() const;

  // The cycle in two halves, for a tracker that gates and assigns (ImmEstimator::predict and what
  // follows it): predict(), then any number of candidate_* questions that change nothing, then
  // update(z) with the plot chosen or miss(). In that order the numbers are exactly those of
  // step(z) and predict_only(). Where the prediction depends on the plot (the learned kinds, a
  // noise schedule: predicts_before_the_plot() is false), a candidate's likelihood is a trial
  // update that is not kept (it writes the filter's scratch: ask one filter from one thread at a
  // time), while its distance (the gate) and predicted_plot() are those of the prediction without
  // a plot (what miss() predicts). A filter without the split (has_split_cycle()
  // false: a wIMM whose update fuses the plot's azimuth with the prediction's) throws
  // std::logic_error from predict(), update() and miss().

  /// Whether predict(), update() and miss() work (false unless the family implements them).
  [[nodiscard]] virtual bool has_split_cycle() const { return false; }
  /// Whether the prediction does not depend on the plot, so that candidates are scored against
  /// one held prediction rather than by trial updates (false unless the family says so).
  [[nodiscard]] virtual bool predicts_before_the_plot() const { return false; }
  /// The first half: the prediction to the next scan, held until update() or miss(). A status
  /// other than kOk holds none.
  virtual StepStatus predict();
  /// After predict(): log p(z | past plots) of a candidate plot; NaN without a held prediction or
  /// for an unusable plot.
  [[nodiscard]] virtual double candidate_log_likelihood(const Eigen::Vector2d& z) const;
  /// After predict(): the candidate's squared distance to the collapsed predicted plot (the
  /// gate's χ²(2) statistic); NaN as candidate_log_likelihood.
  [[nodiscard]] virtual double candidate_distance(const Eigen::Vector2d& z) const;
  /// After predict(): the predicted plot and its covariance (the modes' mixture collapsed); false
  /// without a held prediction.
  virtual bool predicted_plot(Eigen::Vector2d& z_hat, Eigen::Matrix2d& S) const;
  /// The second half with plot z (step(z)'s numbers); on a status other than kOk the prediction
  /// stays held for another plot or miss().
  virtual StepStatus update(const Eigen::Vector2d& z);
  /// The second half without a plot (predict_only()'s numbers).
  virtual StepStatus miss();

  // Time stamps. step(), predict_only() and predict() span the filter's interval: one sample
  // period, or the last one set_interval() took. Driven by times, use step_over() and its siblings
  // below: a filter whose model does not depend on the period (takes_any_interval(): a plain IMM
  // without a learned schedule) predicts over any interval; any other one takes intervals within
  // kIntervalTolerance of a whole number k ≥ 1 of its sample period, as k − 1 cycles without a plot
  // first.

  /// Whether the filter predicts over any interval (false unless the family implements it).
  [[nodiscard]] virtual bool takes_any_interval() const { return false; }
  /// Makes the following cycles span `interval` s: F, Q and the mode transitions remade for it,
  /// without allocating; a held prediction is dropped. False, and nothing changed, unless
  /// takes_any_interval() and the interval is within limits::kSamplePeriod (1 µs to 10 h).
  virtual bool set_interval(double /*interval*/) { return false; }
};

/// How far from a whole number of sample periods an interval may be, as a fraction of the period,
/// for a filter built for one period (1 %: time stamps of a sensor with a little jitter).
inline constexpr double kIntervalTolerance = 0.01;

/// The whole number k ≥ 1 of `period`s that `interval` spans within kIntervalTolerance, or 0.
[[nodiscard]] IMM_RUNTIME_EXPORT std::int64_t whole_periods(double interval, double period);

/// One cycle with plot z, `interval` s after the filter's last one, for a filter built for sample
/// period `period` (see above). kUnsupportedInterval, and nothing changed, for an interval the
/// filter does not take; a failure of one of the k − 1 cycles without a plot is returned with the
/// cycles before it kept.
IMM_RUNTIME_EXPORT StepStatus step_over(TrackFilter& filter, double period, double interval,
                                        const Eigen::Vector2d& z);
/// One cycle without a plot, `interval` s after the last (step_over without z).
IMM_RUNTIME_EXPORT StepStatus predict_only_over(TrackFilter& filter, double period,
                                                double interval);
/// The split cycle's first half (TrackFilter::predict) `interval` s after the last cycle; for a
/// filter of one period the k − 1 cycles between are predicted and kept first.
IMM_RUNTIME_EXPORT StepStatus predict_over(TrackFilter& filter, double period, double interval);

/// The normalized innovation squared νᵀ S⁻¹ ν (by S's Cholesky factor), or nothing when S is not
/// positive definite. Allocation-free.
[[nodiscard]] IMM_RUNTIME_EXPORT std::optional<double> normalized_innovation_squared(
    const Eigen::Vector2d& nu, const Eigen::Matrix2d& S);

/// The normalized innovation squared of the filter's last step (TrackFilter::innovation,
/// normalized_innovation_squared), or nothing when there is none or S is not positive definite.
/// Allocation-free.
[[nodiscard]] IMM_RUNTIME_EXPORT std::optional<double> last_step_nis(const TrackFilter& filter);

}  // namespace imm
