// SPDX-License-Identifier: Apache-2.0
// Whether a learned part of the CV-mode kinds adds anything as one more mode of the tuned CV/CA/CT
// IMM (Cartesian plots):
//   mlp: a constant-velocity mode driven by the neural input estimator's acceleration (seed 001):
//        x⁻ = F x + G û(k−1) per axis, Q = s (q + σ_û²) G Gᵀ with the model's q and σ_û²;
//   fcm: a constant-velocity mode with the FCM compensation (seed 003) at the model's λ, window,
//        fuzzifier and separation, Q = q_j G Gᵀ for one of the model's levels q_j.
// Each axis of the added mode is the model's one-axis mode; the pair is one mode of the 2-D IMM
// (the cross-covariance between the axes is dropped when it mixes, as the per-axis models assume).
// The added mode keeps every stay probability of the tuned IMM: it takes its share 1/n of each
// mode's exits, and leaves for the others evenly. Its noise (s, or the level j) and its own stay
// probability are chosen on the training split by ζ_p + ζ_v from a small grid; the IMM with the
// best of them is then compared with the tuned IMM on the test split, both on the same plots, with
// 95 % paired-bootstrap intervals over the tracks.
//
//   imm-study-carry-over REGIME.toml CLASSICAL.h5 mlp|fcm MODEL.h5 [TRAINING_TRACKS] [SEED]

#include <algorithm>
#include <array>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "imm/datasets/regime_file.hpp"
#include "imm/datasets/track.hpp"
#include "imm/estimation/input_kalman_mode.hpp"
#include "imm/evaluation/monte_carlo.hpp"
#include "imm/evaluation/uncertainty.hpp"
#include "imm/filters/fcm_imm.hpp"
#include "imm/filters/mlp_input_estimator.hpp"
#include "imm/filters/plain_imm.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/tracking/tracker.hpp"
#include "study_main.hpp"

namespace {

using AxisMode = imm::ImmMode<2, 1>;

// Two one-axis modes (x on states [0, 1], y on [y, y + 1]) as one mode of a 2-D IMM with Cartesian
// plots of independent axes; the rest of the mixing space is zero, as for a CV mode.
template <int NX>
class AxisPairMode final : public imm::ImmMode<NX, 2> {
 public:
  static constexpr int kY = NX >= 6 ? 3 : 2;

  AxisPairMode(std::string name, std::unique_ptr<AxisMode> x, std::unique_ptr<AxisMode> y)
      : name_(std::move(name)), axes_{std::move(x), std::move(y)} {}

  [[nodiscard]] std::string_view name() const override { return name_; }

  void embedded_estimate(imm::Vector<NX>& mean, imm::SquareMatrix<NX>& covariance) const override {
    mean.setZero();
    covariance.setZero();
    for (int a = 0; a < 2; ++a) {
      imm::Vector<2> m;
      imm::SquareMatrix<2> P;
      axis(a).embedded_estimate(m, P);
      mean.template segment<2>(offset(a)) = m;
      covariance.template block<2, 2>(offset(a), offset(a)) = P;
    }
  }

  void reset(const imm::GaussianState<NX>& state) override {
    for (int a = 0; a < 2; ++a) axis(a).reset(project(state, a));
  }

  imm::ModeStep propose(const imm::GaussianState<NX>& mixed, const imm::Vector<2>& z) override {
    imm::ModeStep total;
    imm::Vector<2> nu = imm::Vector<2>::Zero();
    imm::SquareMatrix<2> S = imm::SquareMatrix<2>::Zero();
    for (int a = 0; a < 2; ++a) {
      const imm::ModeStep step = axis(a).propose(project(mixed, a), imm::Vector<1>(z(a)));
      if (step.status != imm::StepStatus::kOk) return step;
      total.log_likelihood += step.log_likelihood;
      nu(a) = axis(a).innovation()(0);
      S(a, a) = axis(a).innovation_covariance()(0, 0);
    }
    this->keep_innovation(nu, S);
    return total;
  }

  imm::ModeStep propose_prediction(const imm::GaussianState<NX>& mixed) override {
    for (int a = 0; a < 2; ++a) {
      const imm::ModeStep step = axis(a).propose_prediction(project(mixed, a));
      if (step.status != imm::StepStatus::kOk) return step;
    }
    return {};
  }

  void predicted_mean(const imm::GaussianState<NX>& mixed, imm::Vector<NX>& mean) const override {
    mean.setZero();
    for (int a = 0; a < 2; ++a) {
      imm::Vector<2> m;
      axis(a).predicted_mean(project(mixed, a), m);
      mean.template segment<2>(offset(a)) = m;
    }
  }

  void commit() override {
    for (auto& a : axes_) a->commit();
  }

  [[nodiscard]] AxisMode& axis(int a) const { return *axes_[static_cast<std::size_t>(a)]; }

 private:
  static constexpr int offset(int a) { return a == 0 ? 0 : kY; }
  static imm::GaussianState<2> project(const imm::GaussianState<NX>& state, int a) {
    imm::GaussianState<2> s;
    s.mean = state.mean.template segment<2>(offset(a));
    s.covariance = state.covariance.template block<2, 2>(offset(a), offset(a));
    return s;
  }

  std::string name_;
  std::array<std::unique_ptr<AxisMode>, 2> axes_;
};

// What the added mode is made of.
struct Addition {
  std::string kind;  // "mlp" | "fcm"
  std::optional<imm::MlpInputEstimatorModel> mlp;
  std::optional<imm::FcmImmSpec> fcm;
  double noise = 1.0;  // mlp: the scale s; fcm: the level index j
  double stay = 0.9;
  bool control = false;  // the same mode without its learned part: û = 0, λ = 0
};

// The tuned IMM's transition with one mode more (see the file comment).
void extend(const imm::PlainImmSpec& spec, Eigen::MatrixXd& transition, Eigen::VectorXd& initial,
            double stay) {
  const auto n = spec.transition.rows();
  transition = Eigen::MatrixXd::Zero(n + 1, n + 1);
  const double share = 1.0 / static_cast<double>(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < n; ++j) {
      transition(i, j) = i == j ? spec.transition(i, i) : spec.transition(i, j) * (1.0 - share);
    }
    transition(i, n) = (1.0 - spec.transition(i, i)) * share;
  }
  transition(n, n) = stay;
  for (Eigen::Index j = 0; j < n; ++j) transition(n, j) = (1.0 - stay) / static_cast<double>(n);
  initial.resize(n + 1);
  initial.head(n) =
      spec.initial_probabilities * static_cast<double>(n) / static_cast<double>(n + 1);
  initial(n) = 1.0 / static_cast<double>(n + 1);
}

// The tuned IMM with the added mode, behind TrackFilter.
template <int NX>
class ExtendedImm final : public imm::TrackFilter {
 public:
  ExtendedImm(const imm::PlainImmSpec& spec, const Addition& addition) : spec_(spec) {
    auto modes = imm::build_plain_imm_modes<NX>(spec);
    std::array<std::unique_ptr<AxisMode>, 2> axes;
    for (int a = 0; a < 2; ++a) {
      if (addition.mlp) {
        const imm::MlpInputEstimatorModel& m = *addition.mlp;
        auto mode = std::make_unique<imm::InputKalmanMode>(
            "û", m.settings.sample_period,
            addition.noise * (m.settings.process_noise + m.input_variance),
            m.settings.measurement_variance);
        if (!addition.control) {
          inputs_[static_cast<std::size_t>(a)] = mode.get();
          estimators_[static_cast<std::size_t>(a)].emplace(m, m.settings);
        }
        axes[static_cast<std::size_t>(a)] = std::move(mode);
      } else {
        imm::FcmImmSpec fcm = *addition.fcm;
        if (addition.control) fcm.compensation_gain = 0.0;
        axes[static_cast<std::size_t>(a)] =
            std::make_unique<imm::FcmCompensatedMode>(fcm, static_cast<int>(addition.noise));
      }
    }
    modes.push_back(
        std::make_unique<AxisPairMode<NX>>(addition.kind, std::move(axes[0]), std::move(axes[1])));
    Eigen::MatrixXd transition;
    Eigen::VectorXd initial;
    extend(spec_, transition, initial, addition.stay);
    imm_.emplace(std::move(modes), transition, initial);
  }

  [[nodiscard]] int state_dimension() const override { return NX; }
  [[nodiscard]] int mode_count() const override { return imm_->mode_count(); }
  [[nodiscard]] std::string mode_name(int j) const override {
    return std::string(imm_->mode(j).name());
  }
  void initialize(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) override {
    imm::GaussianState<NX> state;
    state.mean = mean;
    state.covariance = covariance;
    imm_->initialize(state);
    for (int a = 0; a < 2; ++a) {
      auto& estimator = estimators_[static_cast<std::size_t>(a)];
      if (!estimator) continue;
      const int o = a == 0 ? 0 : AxisPairMode<NX>::kY;
      imm::GaussianState<2> axis;
      axis.mean = mean.segment<2>(o);
      axis.covariance = covariance.block<2, 2>(o, o);
      estimator->initialize(axis);
    }
  }
  imm::StepStatus step(const Eigen::Vector2d& z) override {
    set_inputs();
    const imm::StepStatus status = imm_->step(z);
    if (status != imm::StepStatus::kOk) return status;
    for (int a = 0; a < 2; ++a) {
      auto& estimator = estimators_[static_cast<std::size_t>(a)];
      if (estimator) (void)estimator->step(z(a));
    }
    return status;
  }
  imm::StepStatus predict_only() override {
    set_inputs();
    const imm::StepStatus status = imm_->predict_only();
    for (auto& estimator : estimators_) {
      if (estimator) estimator->predict_only();
    }
    return status;
  }
  void state(Eigen::Ref<Eigen::VectorXd> mean,
             Eigen::Ref<Eigen::VectorXd> variance) const override {
    mean = imm_->estimate().mean;
    variance = imm_->estimate().covariance.diagonal();
  }
  void covariance(Eigen::Ref<Eigen::MatrixXd> covariance) const override {
    covariance = imm_->estimate().covariance;
  }
  [[nodiscard]] imm::ModeVector mode_probabilities() const override {
    return imm_->mode_probabilities();
  }
  bool innovation(Eigen::Vector2d& nu, Eigen::Matrix2d& S) const override {
    return imm_->innovation(nu, S);
  }
  [[nodiscard]] double log_predictive_likelihood() const override {
    return imm_->log_predictive_likelihood();
  }

 private:
  void set_inputs() {
    for (std::size_t a = 0; a < 2; ++a) {
      if (estimators_[a]) inputs_[a]->set_input(estimators_[a]->acceleration());
    }
  }

  imm::PlainImmSpec spec_;
  std::optional<imm::ImmEstimator<NX, 2>> imm_;
  std::array<imm::InputKalmanMode*, 2> inputs_{};
  std::array<std::optional<imm::MlpInputEstimatorFilter>, 2> estimators_;
};

std::unique_ptr<imm::TrackFilter> make_extended(const imm::PlainImmSpec& spec,
                                                const Addition& addition) {
  switch (spec.mixing_dimension()) {
    case 4:
      return std::make_unique<ExtendedImm<4>>(spec, addition);
    case 5:
      return std::make_unique<ExtendedImm<5>>(spec, addition);
    case 6:
      return std::make_unique<ExtendedImm<6>>(spec, addition);
    default:
      return std::make_unique<ExtendedImm<7>>(spec, addition);
  }
}

int run(int argc, char** argv) {
  if (argc < 5) {
    std::cerr << "usage: imm-study-carry-over REGIME.toml CLASSICAL.h5 mlp|fcm MODEL.h5 "
                 "[TRAINING_TRACKS] [SEED]\n";
    return 2;
  }
  const imm::datasets::Regime regime = imm::datasets::load_regime(argv[1]).regime;
  const imm::PlainImmSpec classical = imm::io::read_plain_imm(argv[2]);
  if (classical.measurement.kind != imm::MeasurementKind::kCartesian) {
    std::cerr << "imm-study-carry-over: the added modes take Cartesian plots\n";
    return 2;
  }
  Addition addition;
  addition.kind = argv[3];
  std::vector<double> noises;
  if (addition.kind == "mlp") {
    addition.mlp = imm::io::read_mlp_input_estimator(argv[4]);
    noises = {1.0 / 64, 1.0 / 16, 0.25, 1.0, 4.0, 16.0};
  } else if (addition.kind == "fcm") {
    addition.fcm = imm::io::read_fcm_imm(argv[4]);
    addition.fcm->compensate_lowest = true;
    for (int j = 0; j < addition.fcm->mode_count(); ++j) noises.push_back(j);
  } else {
    std::cerr << "imm-study-carry-over: the added mode is mlp or fcm, not " << addition.kind
              << '\n';
    return 2;
  }
  const int training = argc > 5 ? std::atoi(argv[5]) : regime.splits.training;
  const std::uint64_t seed = argc > 6 ? std::strtoull(argv[6], nullptr, 10) : regime.splits.seed;
  namespace ds = imm::datasets;
  namespace ev = imm::evaluation;
  const ds::TrackSet train =
      ds::draw_split(regime, ds::Split::kTraining, regime.splits.seed, training);
  const ds::TrackSet test = ds::draw_split(regime, ds::Split::kTest, seed);
  const imm::TrackOptions options = classical.track_options();
  const auto base = [&] { return imm::make_plain_imm_filter(classical); };
  const auto objective = [](const ev::FilterOutcome& o) { return o.zeta_p + o.zeta_v; };

  const double base_training = objective(ev::run_monte_carlo("CT-IMM-tuned", base, options, train));
  std::cout << "added mode: " << addition.kind << " on " << regime.name << " (" << training
            << " training tracks, seed " << regime.splits.seed
            << "); ζ_p + ζ_v on training: CT-IMM-tuned " << base_training << '\n';
  // The grid's best on the training split; nullopt when none improves on the tuned IMM there (the
  // product's rule: a learned part that does not help on training is switched off).
  const auto tune = [&](bool control) -> std::optional<Addition> {
    std::optional<Addition> best;
    double best_training = base_training;
    for (const double noise : noises) {
      for (const double stay : {0.6, 0.8, 0.9, 0.97, 0.99}) {
        Addition a = addition;
        a.noise = noise;
        a.stay = stay;
        a.control = control;
        const double value = objective(ev::run_monte_carlo(
            "extended", [&] { return make_extended(classical, a); }, options, train));
        if (value < best_training) {
          best_training = value;
          best = a;
        }
      }
    }
    std::cout << (control ? "  without its learned part: " : "  with its learned part: ");
    if (best) {
      std::cout << "noise " << best->noise << ", stay " << best->stay << ", " << best_training;
    } else {
      std::cout << "no grid point improves on training (off)";
    }
    std::cout << '\n';
    return best;
  };
  const std::optional<Addition> learned = tune(false);
  const std::optional<Addition> control = tune(true);

  const ev::FilterOutcome bar = ev::run_monte_carlo("CT-IMM-tuned", base, options, test);
  const auto outcome = [&](const std::optional<Addition>& a) {
    if (!a) return bar;
    return ev::run_monte_carlo(
        "extended", [&] { return make_extended(classical, *a); }, options, test);
  };
  const ev::FilterOutcome with_learned = outcome(learned);
  const ev::FilterOutcome with_control = outcome(control);
  const int runs = static_cast<int>(test.tracks.size());
  std::cout << "\ntest split (" << runs << " tracks, seed " << seed
            << "); differences with 95 % paired-bootstrap intervals\n\n"
            << "| metric | CT-IMM-tuned | + " << addition.kind << " mode | − bar | + its control"
            << " | learned − control |\n|---|---|---|---|---|---|\n";
  const auto row = [&](const char* name, const auto& metric) {
    const auto [b, bs] = metric(bar);
    const auto [l, ls] = metric(with_learned);
    const auto [c, cs] = metric(with_control);
    std::cout << "| " << name << " | " << b << " | " << l << " | "
              << ev::paired_difference(runs, ls, bs).text() << " | " << c << " | "
              << ev::paired_difference(runs, ls, cs).text() << " |\n";
  };
  row("ζ_p", [](const ev::FilterOutcome& o) { return std::pair(o.zeta_p, o.zeta_p_statistic()); });
  row("ζ_v", [](const ev::FilterOutcome& o) { return std::pair(o.zeta_v, o.zeta_v_statistic()); });
  row("position RMSE in manoeuvres", [](const ev::FilterOutcome& o) {
    const ev::HeadlineMetric m = o.maneuver_position_rmse();
    return std::pair(m.value(), m.statistic());
  });
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return imm::studies::study_main("imm-study-carry-over", run, argc, argv);
}
