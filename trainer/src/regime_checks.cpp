// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/regime_checks.hpp"

#include <algorithm>
#include <stdexcept>

#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/track.hpp"

namespace imm::trainer {

void require_per_axis_sensor(const datasets::Regime& regime, const std::string& kind) {
  require_sensor(regime, datasets::SensorKind::kCartesian, kind);
  for (int c = 0; c < regime.case_count(); ++c) {
    const auto& noise = regime.noise_of(c);
    require(noise.sigma(0) == noise.sigma(1) && noise.correlation == 0.0, "regime",
            kind + " needs one plot σ on both axes and no correlation (regime '" + regime.name +
                "', sensor.sigma)");
    require(noise.sigma == regime.sensor.noise.sigma, "regime",
            kind + " is built for one plot σ; regime '" + regime.name +
                "' varies it from case to case");
  }
}

void require_sensor(const datasets::Regime& regime, datasets::SensorKind sensor,
                    const std::string& kind) {
  require(regime.sensor.kind == sensor, "regime",
          kind + " needs a " + std::string(datasets::to_string(sensor)) + " sensor; regime '" +
              regime.name + "' has a " + std::string(datasets::to_string(regime.sensor.kind)) +
              " one (sensor.kind)");
}

void require_training_truth(const datasets::Regime& regime, const std::string& who) {
  if (regime.trains_from_truth()) return;
  const datasets::Recorded& recorded = *regime.recorded;
  const bool partial = !recorded.set->recording_truth.empty();
  const bool has_truth = recorded.set->has_truth || partial;
  const std::string state = !has_truth ? "without truth"
                            : !recorded.truth_for_training
                                ? "with truth for evaluation only (recorded.truth = \"evaluation\")"
                                : "with truth for some recordings only, and the training or "
                                  "validation split holds recordings without it";
  require(false, "recorded.truth",
          "training " + who + " needs the truth of the training split, and regime '" + regime.name +
              "' is recorded " + state +
              "; train a kind that learns from plots alone (the tuned baselines, the GA-fuzzy IMM, "
              "the FCM-IMM, the input estimator, the wIMM) or evaluate on it" +
              (has_truth && !recorded.truth_for_training ? " unless recorded.truth = \"training\""
                                                         : ""));
}

void require_gap_free(const datasets::Regime& regime, const datasets::TrackSet& set) {
  for (std::size_t i = 0; i < set.tracks.size(); ++i) {
    if (set.tracks[i].plots.allFinite()) continue;
    const auto r = static_cast<std::size_t>(set.recorded ? set.recording.at(i) : 0);
    throw std::runtime_error(
        regime.file + ": recorded.set: recording '" +
        (set.recorded ? set.recording_names.at(r) : std::to_string(i)) + "' has a gap in a " +
        std::string(datasets::to_string(set.split)) +
        " window; training from plots needs windows without gaps (import with --scans short "
        "enough to fit between them)");
  }
}

double acceleration_scale(const datasets::Regime& regime) {
  const double a = regime.max_acceleration();
  if (a > 0.0) return a;
  if (regime.process_noise_sigma > 0.0) return 10.0 * regime.process_noise_sigma;
  return 1.0;
}

}  // namespace imm::trainer
