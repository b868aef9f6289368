// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/training_set.hpp"

#include "imm/datasets/sha256.hpp"
#include "imm/datasets/track.hpp"
#include "imm/trainer/regime_checks.hpp"

namespace imm::trainer {

std::string TrainingSet::digest() const {
  datasets::Sha256 hash;
  for (const auto& t : trajectories) {
    for (const Eigen::VectorXd* v :
         {&t.position, &t.velocity, &t.acceleration_input, &t.measurement}) {
      hash.update(v->data(), static_cast<std::size_t>(v->size()) * sizeof(double));
    }
  }
  return hash.hex_digest();
}

long TrainingSet::total_steps() const {
  long steps = 0;
  for (const auto& t : trajectories) steps += t.measurement.size();
  return steps;
}

TrainingSet make_training_set(const datasets::Regime& regime, datasets::Split split) {
  TrainingSet set;
  set.sample_period = regime.sample_period;
  set.measurement_variance = regime.sensor.noise.sigma(0) * regime.sensor.noise.sigma(0);
  set.plots_only = !regime.trains_from_truth();
  const datasets::TrackSet tracks = datasets::draw_split(regime, split, regime.splits.seed);
  if (set.plots_only) require_gap_free(regime, tracks);
  set.trajectories = datasets::axis_trajectories(tracks);
  return set;
}

}  // namespace imm::trainer
