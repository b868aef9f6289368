#include "imm/trainer/ga/training_set.hpp"

#include "imm/datasets/random.hpp"
#include "imm/datasets/sha256.hpp"

namespace imm::trainer::ga {

std::string_view to_string(TrainingProfile profile) {
  return profile == TrainingProfile::kManeuver ? "maneuver" : "mixed";
}

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

TrainingSet make_training_set(const TrainingSetOptions& options) {
  TrainingSet set;
  set.sample_period = options.sample_period;
  set.measurement_variance = options.measurement_sigma * options.measurement_sigma;
  const datasets::AxisNoise noise{options.sample_period, options.process_noise_sigma,
                                  options.measurement_sigma};
  for (int t = 0; t < options.trajectories; ++t) {
    datasets::Rng rng(datasets::derive_seed(options.seed, static_cast<std::uint64_t>(t)));
    const int n = options.steps;
    Eigen::VectorXd input = Eigen::VectorXd::Zero(n);
    // The input profile.
    if (options.profile == TrainingProfile::kManeuver) {
      const double sign = rng.uniform() < 0.5 ? -1.0 : 1.0;
      input.setConstant(sign * options.maneuver_level);
    } else {
      int k = 0;
      bool maneuvering = rng.uniform() < 0.5;
      const std::uint64_t span = static_cast<std::uint64_t>(options.max_segment) -
                                 static_cast<std::uint64_t>(options.min_segment) + 1;
      while (k < n) {
        const int length = options.min_segment + static_cast<int>(rng.below(span));
        const double u =
            maneuvering ? (rng.uniform() < 0.5 ? -1.0 : 1.0) * options.maneuver_level : 0.0;
        for (int i = k; i < std::min(n, k + length); ++i) input(i) = u;
        k += length;
        maneuvering = !maneuvering;
      }
    }
    const double speed = (rng.uniform() < 0.5 ? -1.0 : 1.0) * options.initial_speed;
    set.trajectories.push_back(datasets::simulate_axis(0.0, speed, input, noise, rng));
  }
  return set;
}

}  // namespace imm::trainer::ga
