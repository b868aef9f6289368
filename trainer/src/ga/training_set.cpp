#include "imm/trainer/ga/training_set.hpp"

#include "imm/datasets/random.hpp"
#include "imm/datasets/sha256.hpp"
#include "imm/models/constant_velocity.hpp"

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
  const double T = options.sample_period;
  const auto motion = constant_velocity<1>(T, 0.0);
  const Vector<2> G = cv_axis_input_gain(T);
  TrainingSet set;
  set.sample_period = T;
  set.measurement_variance = options.measurement_sigma * options.measurement_sigma;
  for (int t = 0; t < options.trajectories; ++t) {
    datasets::Rng rng(datasets::derive_seed(options.seed, static_cast<std::uint64_t>(t)));
    AxisTrajectory trajectory;
    const int n = options.steps;
    trajectory.position.resize(n);
    trajectory.velocity.resize(n);
    trajectory.acceleration_input.resize(n);
    trajectory.measurement.resize(n);
    // The input profile.
    if (options.profile == TrainingProfile::kManeuver) {
      const double sign = rng.uniform() < 0.5 ? -1.0 : 1.0;
      trajectory.acceleration_input.setConstant(sign * options.maneuver_level);
    } else {
      int k = 0;
      bool maneuvering = rng.uniform() < 0.5;
      const std::uint64_t span = static_cast<std::uint64_t>(options.max_segment) -
                                 static_cast<std::uint64_t>(options.min_segment) + 1;
      while (k < n) {
        const int length = options.min_segment + static_cast<int>(rng.below(span));
        const double u =
            maneuvering ? (rng.uniform() < 0.5 ? -1.0 : 1.0) * options.maneuver_level : 0.0;
        for (int i = k; i < std::min(n, k + length); ++i) trajectory.acceleration_input(i) = u;
        k += length;
        maneuvering = !maneuvering;
      }
    }
    Vector<2> x(0.0, (rng.uniform() < 0.5 ? -1.0 : 1.0) * options.initial_speed);
    for (int k = 0; k < n; ++k) {
      trajectory.position(k) = x(0);
      trajectory.velocity(k) = x(1);
      trajectory.measurement(k) = x(0) + options.measurement_sigma * rng.normal();
      const double w = options.process_noise_sigma * rng.normal();
      x = motion.transition * x + G * (trajectory.acceleration_input(k) + w);
    }
    set.trajectories.push_back(std::move(trajectory));
  }
  return set;
}

}  // namespace imm::trainer::ga
