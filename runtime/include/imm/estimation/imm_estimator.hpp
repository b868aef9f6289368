// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Interacting multiple model estimator (Blom & Bar-Shalom; seed 000 eq. 4–11) over modes that
/// may have different state dimensions.
///
/// One step, with Π = [p_ij] the mode transition matrix and μ the mode probabilities:
///   1. predicted mode probabilities c_j = Σ_i p_ij μ_i, mixing weights μ_ij = p_ij μ_i / c_j (6);
///   2. mixed initial conditions x̂₀ⱼ = Σ_i μ_ij x̂_i, P₀ⱼ = Σ_i μ_ij (P_i + (x̂_i − x̂₀ⱼ)(·)ᵀ) (4–5),
///      formed in the NX-dimensional mixing space where lower-dimensional modes are zero-padded;
///   3. each mode predicts from its mixed condition and updates with z (7 / 19);
///   4. μ_j ∝ Λ_j c_j (8–9), computed as log μ_j = log Λ_j + log c_j − log Σ exp(·): far-off modes
///      have likelihoods that underflow in linear space, never in log space;
///
/// Underflow: μ is stored as log μ. Steps 1–2 work on μ scaled by its largest entry
/// (μ̃_i = exp(log μ_i − max log μ) ∈ (0, 1]), which is exact and costs one exponential per mode
/// instead of one per (i, j) pair; entries below 1e-308 of the largest vanish there, as they would
/// in any floating-point sum. Where a c̃_j underflows to zero (possible only with zero
/// transition entries) log c_j falls back to the exact log-sum-exp.
///   5. combined estimate x̂ = Σ μ_j x̂_j, P = Σ μ_j (P_j + (x̂_j − x̂)(·)ᵀ) (10–11).
///
/// Failure handling: a NaN/Inf measurement, a singular innovation covariance or a non-finite
/// result in any mode returns that status and leaves every mode, μ and the combined estimate as
/// they were. Nothing is allocated per step: mode-indexed arrays have a fixed maximum size
/// (kMaxModes) and modes are allocation-free by contract.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "imm/core/checks.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/estimation/gaussian_state.hpp"
#include "imm/estimation/imm_mode.hpp"
#include "imm/estimation/mode_transitions.hpp"
#include "imm/estimation/step_status.hpp"
#include "imm/math/linear_algebra.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// The interacting multiple model estimator over modes of one mixing space (see the file comment).
template <int NX, int NZ>
class ImmEstimator {
 public:
  /// The modes' interface.
  using Mode = ImmMode<NX, NZ>;
  /// The mixing-space dimension.
  static constexpr int kDim = NX;
  /// The measurement dimension.
  static constexpr int kMeasurementDim = NZ;

  /// `transition(i, j)` is the probability of switching from mode i to mode j (rows sum to 1);
  /// `initial_probabilities` sum to 1. Throws std::invalid_argument naming the offending entry.
  ImmEstimator(std::vector<std::unique_ptr<Mode>> modes, const Eigen::MatrixXd& transition,
               const Eigen::VectorXd& initial_probabilities)
      : modes_(std::move(modes)) {
    const int n = static_cast<int>(modes_.size());
    if (n < 1 || n > kMaxModes) {
      throw std::invalid_argument("an IMM needs 1 to " + std::to_string(kMaxModes) +
                                  " modes, got " + std::to_string(n));
    }
    for (const auto& mode : modes_) {
      if (!mode) throw std::invalid_argument("IMM mode is null");
    }
    validate_mode_probabilities(transition, initial_probabilities, n);
    transition_ = transition;
    per_period_transition_ = transition;
    log_transition_.resize(n, n);
    initial_log_probabilities_.resize(n);
    for (int i = 0; i < n; ++i) {
      initial_log_probabilities_(i) = safe_log(initial_probabilities(i));
      for (int j = 0; j < n; ++j) log_transition_(i, j) = safe_log(transition(i, j));
    }
    log_probabilities_ = initial_log_probabilities_;
    log_predicted_.resize(n);
    predicted_scaled_.resize(n);
    log_posterior_.resize(n);
    scaled_.resize(n);
    scratch_.resize(n);
  }

  /// Movable, not copyable (it owns its modes).
  ImmEstimator(ImmEstimator&&) noexcept = default;
  /// Move assignment.
  ImmEstimator& operator=(ImmEstimator&&) noexcept = default;

  /// Starts a track: every mode takes `state` (its own components of it) and the mode
  /// probabilities return to their initial values.
  void initialize(const GaussianState<NX>& state) {
    updated_ = false;
    predicted_ = false;
    for (auto& mode : modes_) mode->reset(state);
    log_probabilities_ = initial_log_probabilities_;
    combine();
    initialized_ = true;
  }

  /// One IMM cycle with measurement z. On any status other than kOk nothing changes. Flattened:
  /// every call inside is inlined (Eigen's small products otherwise stay out of line).
  [[gnu::flatten]] StepStatus step(const Vector<NZ>& z) {
    require_initialized();
    updated_ = false;
    predicted_ = false;
    if (!limits::usable_measurement(z)) return StepStatus::kInvalidMeasurement;
    predict_mode_probabilities();
    mix_and_propose(
        [&](Mode& mode, const GaussianState<NX>& mixed) { return mode.propose(mixed, z); });
    return finish_update();
  }

  /// One IMM cycle without a measurement (a missed or rejected plot): the modes predict and the
  /// mode probabilities only follow the Markov chain.
  StepStatus predict_only() {
    require_initialized();
    updated_ = false;
    predicted_ = false;
    predict_mode_probabilities();
    mix_and_propose(
        [](Mode& mode, const GaussianState<NX>& mixed) { return mode.propose_prediction(mixed); });
    return finish_cycle();
  }

  /// One IMM cycle in which the measurement is chosen after the prediction: `choose` receives the
  /// predicted mode probabilities c_j = Σ_i p_ij μ_i (linear), every mode's predicted mean in
  /// mixing space and z, and returns the measurement to update with (seed 004's weighted IMM
  /// fuses the plot azimuth with the predicted one). On any status other than kOk nothing
  /// changes.
  template <class Choose>
  StepStatus step_with(const Vector<NZ>& z, Choose&& choose) {
    require_initialized();
    updated_ = false;
    predicted_ = false;
    if (!limits::usable_measurement(z)) return StepStatus::kInvalidMeasurement;
    predict_mode_probabilities();
    const int n = mode_count();
    ModeVector predicted(n);
    for (int j = 0; j < n; ++j) {
      predicted(j) = std::exp(log_predicted_(j));
      mix(j, mixed_states_[index(j)]);
      mode_at(j).predicted_mean(mixed_states_[index(j)], predicted_means_[index(j)]);
    }
    const Vector<NZ> chosen =
        choose(static_cast<const ModeVector&>(predicted),
               static_cast<const std::array<Vector<NX>, kMaxModes>&>(predicted_means_), z);
    if (!limits::usable_measurement(chosen)) return StepStatus::kInvalidMeasurement;
    status_ = StepStatus::kOk;
    for (int j = 0; j < n; ++j) {
      if (!record(j, mode_at(j).propose(mixed_states_[index(j)], chosen))) break;
    }
    return finish_update();
  }

  // --- A cycle in two halves, for a tracker that gates and assigns plots -----------------------
  // predict(); then, without changing the track, predicted_plot() and, for every candidate plot,
  // candidate_log_likelihood() and candidate_distance(); then update(z) with the plot chosen, or
  // miss(). In that order the numbers are exactly those of step(z) and predict_only(). Where
  // every mode predicts before the plot (predicts_before_the_plot()), predict() holds the modes'
  // predictions and a candidate costs one innovation per mode. Where a mode's prediction depends
  // on the plot (a learned noise or compensation), predict() holds the mixing; a candidate's
  // likelihood is a trial update (each mode's propose() of it into its pending slot, which
  // commit() alone would make current, so the track does not change), and its distance and the
  // predicted plot are those of the prediction without a plot (what miss() predicts).

  /// Whether every mode predicts over any positive interval (ImmMode::takes_any_interval).
  [[nodiscard]] bool takes_any_interval() const {
    for (const auto& mode : modes_) {
      if (!mode->takes_any_interval()) return false;
    }
    return true;
  }
  /// Makes the following cycles span `interval` s, which is `periods` of the sample period Π is
  /// given for: every mode's F and Q remade (ImmMode::set_interval) and Π over the interval
  /// (transition_over). Allocation-free. False, and nothing changed, unless takes_any_interval(),
  /// the interval is within the limits of a sample period (limits::kSamplePeriod: 1 µs to 10 h)
  /// and `periods` is positive and finite; a held prediction (predict()) is dropped.
  bool set_interval(double interval, double periods) {
    if (!takes_any_interval() || !limits::kSamplePeriod.contains(interval) || !(periods > 0.0) ||
        !std::isfinite(periods)) {
      return false;
    }
    // Within those limits every mode's F and Q are finite: no mode refuses after another took it.
    for (auto& mode : modes_) {
      if (!mode->set_interval(interval)) return false;
    }
    if (periods != periods_) {
      transition_over(per_period_transition_, periods, transition_);
      const int n = mode_count();
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) log_transition_(i, j) = safe_log(transition_(i, j));
      }
      periods_ = periods;
    }
    predicted_ = false;
    return true;
  }

  /// Whether every mode predicts without the plot (see ImmMode::predicts_before_the_plot): a
  /// candidate is then scored against one held prediction; otherwise by a trial update.
  [[nodiscard]] bool predicts_before_the_plot() const {
    for (const auto& mode : modes_) {
      if (!mode->predicts_before_the_plot()) return false;
    }
    return true;
  }

  /// The first half of a cycle: the predicted mode probabilities, the mixing and every mode's
  /// prediction (the mixing alone where predicts_before_the_plot() is false), held until update()
  /// or miss(); the track does not change. kOk, or the failing mode's status (nothing is then
  /// held).
  StepStatus predict();

  /// Whether predict() holds a prediction (until update() succeeds or miss()).
  [[nodiscard]] bool predicted() const { return predicted_; }

  /// After predict(): log p(z | Z^(k−1)) = log Σ_j c_j N(z; ẑ_j, S_j) of a candidate plot, what
  /// log_predictive_likelihood() would be after update(z); nothing changes (a trial update writes
  /// only the modes' pending slots). NaN without a held prediction, for an unusable plot, or
  /// where a mode cannot score it.
  [[nodiscard]] double candidate_log_likelihood(const Vector<NZ>& z) const;

  /// After predict(): the normalized distance d² = νᵀ S⁻¹ ν of a candidate plot under the IMM's
  /// predicted plot density collapsed to its two moments (ν = Σ_j c_j ν_j, S as innovation()):
  /// the gate's statistic, χ² with NZ degrees of freedom where the filter is consistent. Where
  /// candidates are trial updates, under the prediction without the plot (predicted_plot()'s):
  /// a learned noise that grows with the plot's own innovation would otherwise widen the gate for
  /// every far plot. Nothing changes; NaN for an unusable plot or where S is not positive
  /// definite.
  [[nodiscard]] double candidate_distance(const Vector<NZ>& z) const;

  /// After predict(): mode j's predicted plot ẑ_j and its covariance S_j; false without a held
  /// prediction or where the mode's h is undefined at its prediction. Where a mode's prediction
  /// depends on the plot, the prediction without it (what miss() predicts); false where the mode
  /// cannot state it.
  bool predicted_plot(int j, Vector<NZ>& z_hat, SquareMatrix<NZ>& S) const {
    return predicted_ && predict_without_the_plot() && modes_[index(j)]->predicted_plot(z_hat, S);
  }

  /// After predict(): the IMM's predicted plot and covariance, the two moments of
  /// Σ_j c_j N(ẑ_j, S_j), in the plot coordinates of the most probable mode's ẑ (angles are not
  /// averaged across the ±π seam); false as predicted_plot(j, …).
  bool predicted_plot(Vector<NZ>& z_hat, SquareMatrix<NZ>& S) const;

  /// The second half, with the chosen plot: the same numbers as step(z) after the same predict().
  /// On any status other than kOk nothing changes and the prediction is still held, for another
  /// plot or miss().
  StepStatus update(const Vector<NZ>& z);

  /// The second half without a plot (a miss, or every candidate gated out): the same numbers as
  /// predict_only() after the same predict().
  StepStatus miss();

  /// Whether initialize() has been called.
  [[nodiscard]] bool initialized() const { return initialized_; }
  /// The combined estimate (eq. 10–11 of seed 000).
  [[nodiscard]] const GaussianState<NX>& estimate() const { return combined_; }
  /// The number of modes.
  [[nodiscard]] int mode_count() const { return static_cast<int>(modes_.size()); }
  /// Mode j (0-based).
  [[nodiscard]] const Mode& mode(int j) const { return *modes_[index(j)]; }

  /// Mode probabilities μ_j (linear space; may contain exact zeros after underflow).
  [[nodiscard]] ModeVector mode_probabilities() const {
    ModeVector mu(mode_count());
    for (int j = 0; j < mode_count(); ++j) mu(j) = std::exp(log_probabilities_(j));
    return mu;
  }

  /// log μ_j, exact where linear probabilities underflow.
  [[nodiscard]] const ModeVector& log_mode_probabilities() const { return log_probabilities_; }

  /// log p(z | Z^(k−1)) of the last plot under the IMM's predicted measurement density,
  /// log Σ_j c_j N(ν_j; 0, S_j) (c_j the predicted mode probabilities): the predictive
  /// log-likelihood that learning from plots alone maximizes. NaN unless the last call was a
  /// successful step() or step_with(). Computed here from the cycle's ℓ_j + log c_j, so the
  /// filter step pays nothing for it.
  [[nodiscard]] double log_predictive_likelihood() const {
    if (!updated_) return std::numeric_limits<double>::quiet_NaN();
    return log_sum_exp(log_posterior_);
  }

  /// The innovation of the last cycle and its covariance, as the moments of the IMM's predicted
  /// measurement density Σ_j c_j N(ẑ_j, S_j) (c_j the predicted mode probabilities):
  /// ν = z − ẑ = Σ_j c_j ν_j and S = Σ_j c_j (S_j + (ν_j − ν)(ν_j − ν)ᵀ), so that νᵀ S⁻¹ ν is the
  /// filter's normalized innovation squared (NIS; Bar-Shalom, Li & Kirubarajan §5.4.2, with the
  /// mixture collapsed to its first two moments). The measurement is the one the modes updated
  /// with (step_with's chosen one). False, and nothing written, unless the last call was a
  /// successful step() or step_with(). Computed here, not in the cycle: the filter step pays
  /// nothing for it.
  bool innovation(Vector<NZ>& nu, SquareMatrix<NZ>& S) const {
    return innovation(nu, S, [](Vector<NZ>&, SquareMatrix<NZ>&) {});
  }

  /// innovation() of another measurement than the one the modes updated with: `to_plot(ν_j, S_j)`
  /// rewrites every mode's innovation and its covariance in place into that measurement's (the
  /// weighted IMM updates with a fused azimuth and reports the plot's).
  template <class ToPlot>
  bool innovation(Vector<NZ>& nu, SquareMatrix<NZ>& S, ToPlot&& to_plot) const {
    return updated_ && collapse(innovations_of_the_update(to_plot), nu, S);
  }

  /// log_predictive_likelihood() of another measurement than the one the modes updated with
  /// (`to_plot` as for innovation()): log Σ_j c_j N(ν_j'; 0, S_j'), with the mode's ν_j, S_j
  /// rewritten. NaN unless the last call was a successful update, or where an S_j' is not
  /// positive definite.
  template <class ToPlot>
  [[nodiscard]] double log_predictive_likelihood(ToPlot&& to_plot) const {
    if (!updated_) return std::numeric_limits<double>::quiet_NaN();
    return mixture_log_density(innovations_of_the_update(to_plot));
  }

 private:
  void require_initialized() const {
    if (!initialized_) throw std::logic_error("ImmEstimator used before initialize()");
  }
  void require_predicted() const {
    if (!predicted_) throw std::logic_error("ImmEstimator: update() or miss() without predict()");
  }

  // The IMM's plot density Σ_j c_j N(ν_j; 0, S_j) (c_j the predicted mode probabilities) from
  // every mode's innovation, which `of(j, ν_j, S_j)` writes (false: that mode cannot give one).
  // collapse(): its two moments ν = Σ_j c_j ν_j and S = Σ_j c_j (S_j + (ν_j − ν)(ν_j − ν)ᵀ),
  // c_j normalized; false where a mode gave none. mixture_log_density(): log Σ_j c_j N(ν_j; 0,
  // S_j); NaN where a mode gave none or an S_j is not positive definite.
  template <class Of>
  bool collapse(Of&& of, Vector<NZ>& nu, SquareMatrix<NZ>& S) const;
  template <class Of>
  [[nodiscard]] double mixture_log_density(Of&& of) const;
  // `of` for the innovations of the last update, rewritten by `to_plot` (see innovation()).
  template <class ToPlot>
  auto innovations_of_the_update(ToPlot& to_plot) const {
    return [this, &to_plot](int j, Vector<NZ>& nu, SquareMatrix<NZ>& S) {
      nu = modes_[index(j)]->innovation();
      S = modes_[index(j)]->innovation_covariance();
      to_plot(nu, S);
      return true;
    };
  }
  // `of` for a candidate plot under the held prediction.
  auto innovations_of_candidate(const Vector<NZ>& z) const {
    return [this, &z](int j, Vector<NZ>& nu, SquareMatrix<NZ>& S) {
      return modes_[index(j)]->candidate_innovation(z, nu, S);
    };
  }
  // A trial update of every mode with z from the held mixing, into the modes' pending slots (the
  // modes are reached through their pointers: a pending slot is scratch until commit()). False
  // where a mode refused z; `log_likelihoods` gets each mode's ℓ_j.
  bool trial_update(const Vector<NZ>& z, ModeVector& log_likelihoods) const {
    if (!limits::usable_measurement(z)) return false;
    plot_free_pending_ = false;
    for (int j = 0; j < mode_count(); ++j) {
      const ModeStep result = modes_[index(j)]->propose(mixed_states_[index(j)], z);
      if (result.status != StepStatus::kOk) return false;
      log_likelihoods(j) = result.log_likelihood;
    }
    return true;
  }
  // Where the held mixing is a trial's: every mode's prediction without a plot into its pending
  // slot, for predicted_plot() and candidate_distance() — made once, until a trial or an update
  // writes the slots. True where every mode predicted (always, for a held prediction).
  bool predict_without_the_plot() const {
    if (!trial_ || plot_free_pending_) return true;
    for (int j = 0; j < mode_count(); ++j) {
      const ModeStep result = modes_[index(j)]->propose_prediction(mixed_states_[index(j)]);
      if (result.status != StepStatus::kOk) return false;
    }
    plot_free_pending_ = true;
    return true;
  }

  // log c_j = log Σ_i p_ij μ_i (eq. 8's inner sum), through the scaled μ̃ (see the class comment).
  void predict_mode_probabilities();

  // The mixed initial condition of mode j (eq. 4–6).
  [[gnu::always_inline]] inline void mix(int j, GaussianState<NX>& mixed);

  // Mixing and the modes' predict/update. Stops at the first failing mode.
  template <class Propose>
  void mix_and_propose(Propose&& propose) {
    status_ = StepStatus::kOk;
    for (int j = 0; j < mode_count(); ++j) {
      mix(j, mixed_);
      if (!record(j, propose(mode_at(j), mixed_))) return;
    }
  }

  // Stores mode j's result; false (and status_ set) when it failed.
  bool record(int j, const ModeStep& result) {
    if (result.status != StepStatus::kOk) {
      status_ = result.status;
      return false;
    }
    log_posterior_(j) = result.log_likelihood + log_predicted_(j);
    return true;
  }

  // finish_cycle() after an update with a measurement: innovation() is defined when it succeeds.
  StepStatus finish_update() {
    const StepStatus status = finish_cycle();
    updated_ = status == StepStatus::kOk;
    return status;
  }

  // Normalizes the posterior in log space, commits the modes and combines.
  StepStatus finish_cycle();

  // Combination (eq. 10–11) with mode probabilities `mu` (linear, summing to 1). Refreshes
  // means_/covariances_ with the modes' current estimates, which the next mixing reuses: they
  // change only in initialize() and finish_cycle(), both of which end here.
  void combine(const ModeVector& mu);
  // Combination with the current μ (initialize()).
  void combine();

  // Σ w_i N(means_i, covariances_i) collapsed to one Gaussian (weights sum to 1). The result is
  // exactly symmetric when the inputs are: entries (a, b) and (b, a) see the same operations.
  void moment_match(const ModeVector& weights, GaussianState<NX>& out) const;

  static std::size_t index(int i) { return static_cast<std::size_t>(i); }
  Mode& mode_at(int i) { return *modes_[index(i)]; }

  std::vector<std::unique_ptr<Mode>> modes_;
  ModeMatrix transition_;             // Π over the current interval
  ModeMatrix per_period_transition_;  // Π over one sample period, as given
  double periods_ = 1.0;              // the current interval in sample periods
  ModeMatrix log_transition_;
  ModeVector initial_log_probabilities_;
  ModeVector log_probabilities_;
  ModeVector log_predicted_;
  ModeVector predicted_scaled_;  // c̃_j = c_j / max μ
  ModeVector log_posterior_;
  ModeVector scaled_;  // μ̃ (prediction) or posterior weights (combination)
  ModeVector scratch_;
  std::array<Vector<NX>, kMaxModes> means_{};  // embedded current mode estimates
  std::array<SquareMatrix<NX>, kMaxModes> covariances_{};
  GaussianState<NX> mixed_;
  std::array<GaussianState<NX>, kMaxModes> mixed_states_{};  // step_with() only
  std::array<Vector<NX>, kMaxModes> predicted_means_{};
  GaussianState<NX> combined_;
  StepStatus status_ = StepStatus::kOk;
  bool initialized_ = false;
  bool updated_ = false;    // the last call was a successful update (innovation())
  bool predicted_ = false;  // predict() holds a prediction (mixed_states_, the modes' pending)
  bool prediction_intact_ = false;  // and no update() has been tried on it since
  bool trial_ = false;              // predict() held the mixing alone: candidates are trial updates
  // Under a trial, the modes' pending slots hold their predictions without a plot (scratch).
  mutable bool plot_free_pending_ = false;
};

}  // namespace imm

// The arithmetic of the cycle and its two halves (predict … update / miss), defined apart.
#include "imm/estimation/imm_estimator_arithmetic.hpp"
#include "imm/estimation/imm_estimator_split.hpp"
