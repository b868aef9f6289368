// SPDX-License-Identifier: Apache-2.0
// How well two filters know the target's acceleration, on a regime's test tracks: the neural input
// estimator (seed 001) through its estimate û per axis, and the tuned CV/CA/CT IMM through its
// moment-matched state, â = (ax − ω vy, ay + ω vx) — the CA mode's acceleration and the CT mode's
// centripetal one, each weighted by its mode probability. Error: ‖â − a‖ against the commanded
// acceleration of the transition that ended at the scan, RMS over all scans after the start and
// over the manoeuvring ones; "none" is â = 0. What it says: whether the input estimator's
// acceleration would add anything to the IMM as the known input of a mode (docs/methods.md).
//
//   imm-study-acceleration REGIME.toml CLASSICAL.h5 MLP.h5 [TRACKS] [SEED]

#include <array>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <string>

#include "imm/datasets/regime_file.hpp"
#include "imm/datasets/track.hpp"
#include "imm/filters/mlp_input_estimator.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/tracking/tracker.hpp"
#include "study_main.hpp"

namespace {

struct Rms {
  double sum = 0.0;
  long count = 0;
  void add(double squared) {
    sum += squared;
    ++count;
  }
  [[nodiscard]] double value() const {
    return count > 0 ? std::sqrt(sum / static_cast<double>(count)) : std::nan("");
  }
};

struct Errors {
  Rms all, maneuvering;
  void add(const Eigen::Vector2d& estimate, const Eigen::Vector2d& truth, bool maneuver) {
    const double e = (estimate - truth).squaredNorm();
    all.add(e);
    if (maneuver) maneuvering.add(e);
  }
};

int run(int argc, char** argv) {
  if (argc < 4) {
    std::cerr << "usage: imm-study-acceleration REGIME.toml CLASSICAL.h5 MLP.h5 [TRACKS] [SEED]\n";
    return 2;
  }
  const imm::datasets::Regime regime = imm::datasets::load_regime(argv[1]).regime;
  const imm::PlainImmSpec classical = imm::io::read_plain_imm(argv[2]);
  const imm::MlpInputEstimatorModel mlp = imm::io::read_mlp_input_estimator(argv[3]);
  const int tracks = argc > 4 ? std::atoi(argv[4]) : regime.splits.test;
  const std::uint64_t seed = argc > 5 ? std::strtoull(argv[5], nullptr, 10) : 1;
  const imm::datasets::TrackSet data =
      imm::datasets::draw_split(regime, imm::datasets::Split::kTest, seed, tracks);
  const double T = regime.sample_period;
  const double r = mlp.settings.measurement_variance;
  Errors imm_errors, mlp_errors, none;
  for (const imm::datasets::Track& track : data.tracks) {
    imm::PlainImmTracker tracker(classical);
    const int n = tracker.state_dimension();
    Eigen::VectorXd mean(n), variance(n);
    const bool accelerations = n >= 6;
    const int omega = classical.has_turn_rate() ? n - 1 : -1;
    const int y = accelerations ? 3 : 2;
    std::array<std::optional<imm::MlpInputEstimatorFilter>, 2> axes;
    for (int k = 0; k < data.scans; ++k) {
      const Eigen::Vector2d z = track.plots.row(k).transpose();
      (void)tracker.process(k, z);
      if (k == 1) {  // both filters start from the same two-point estimate
        for (int a = 0; a < 2; ++a) {
          imm::GaussianState<2> start;
          start.mean << z(a), (z(a) - track.plots(0, a)) / T;
          start.covariance << r, r / T, r / T, 2.0 * r / (T * T);
          axes[static_cast<std::size_t>(a)].emplace(mlp, mlp.settings);
          axes[static_cast<std::size_t>(a)]->initialize(start);
        }
        continue;
      }
      if (k < 2 || !tracker.initialized()) continue;
      for (int a = 0; a < 2; ++a) (void)axes[static_cast<std::size_t>(a)]->step(z(a));
      tracker.state(mean, variance);
      Eigen::Vector2d imm_acceleration = Eigen::Vector2d::Zero();
      if (accelerations) imm_acceleration << mean(2), mean(5);
      if (omega >= 0) {
        imm_acceleration += mean(omega) * Eigen::Vector2d(-mean(y + 1), mean(1));
      }
      const Eigen::Vector2d mlp_acceleration(axes[0]->acceleration(), axes[1]->acceleration());
      const Eigen::Vector2d truth = imm::datasets::acceleration_at(track, k - 1);
      const bool maneuver = track.maneuvering[static_cast<std::size_t>(k - 1)];
      imm_errors.add(imm_acceleration, truth, maneuver);
      mlp_errors.add(mlp_acceleration, truth, maneuver);
      none.add(Eigen::Vector2d::Zero(), truth, maneuver);
    }
  }
  const std::string unit = std::string(imm::datasets::to_string(regime.units)) + "/s²";
  std::cout << "acceleration estimates on " << regime.name << "'s test split (" << tracks
            << " tracks, seed " << seed << "): RMS of ‖â − a‖ in " << unit << "\n\n"
            << "| estimate | all scans | manoeuvring scans |\n|---|---|---|\n";
  const auto row = [](const char* name, const Errors& e) {
    std::cout << "| " << name << " | " << e.all.value() << " | " << e.maneuvering.value() << " |\n";
  };
  row("CV/CA/CT IMM (moment-matched)", imm_errors);
  row("neural input estimator û", mlp_errors);
  row("none (â = 0)", none);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return imm::studies::study_main("imm-study-acceleration", run, argc, argv);
}
