// SPDX-License-Identifier: Apache-2.0
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/random.hpp"
#include "imm/datasets/recorded.hpp"

namespace imm::datasets {
namespace {

// The stream of splits.seed the recordings are shuffled with.
constexpr std::uint64_t kRecordedShuffleStream = 0x5245'4344ULL;

const std::vector<int>& recordings_of(const Recorded& recorded, Split split) {
  switch (split) {
    case Split::kTraining:
      return recorded.training;
    case Split::kValidation:
      return recorded.validation;
    case Split::kTest:
      break;
  }
  return recorded.test;
}

// The set's windows of one split, in the order of its recordings.
std::vector<std::size_t> windows_of(const Recorded& recorded, Split split) {
  std::vector<std::size_t> windows;
  for (const int r : recordings_of(recorded, split)) {
    for (std::size_t i = 0; i < recorded.set->recording.size(); ++i) {
      if (recorded.set->recording[i] == r) windows.push_back(i);
    }
  }
  return windows;
}

}  // namespace

void assign_recorded_splits(Recorded& recorded, const Splits& splits) {
  std::vector<int> order(recorded.set->recording_names.size());
  std::iota(order.begin(), order.end(), 0);
  Rng rng(derive_seed(splits.seed, kRecordedShuffleStream));
  for (std::size_t i = order.size(); i > 1; --i) {  // Fisher–Yates
    std::swap(order[i - 1], order[rng.below(i)]);
  }
  const auto deal = [&](std::size_t from, int count) {
    const std::size_t to = std::min(order.size(), from + static_cast<std::size_t>(count));
    return std::vector<int>(order.begin() + static_cast<long>(std::min(from, to)),
                            order.begin() + static_cast<long>(to));
  };
  const auto training = static_cast<std::size_t>(splits.training);
  const auto validation = static_cast<std::size_t>(splits.validation);
  const TrackSet& set = *recorded.set;
  if (set.recording_truth.empty()) {  // truth for all recordings or none
    recorded.training = deal(0, splits.training);
    recorded.validation = deal(training, splits.validation);
    recorded.test = deal(training + validation, splits.test);
  } else {
    // Partial truth: the recordings with truth go first (in their shuffled order) to where the
    // regime uses it — the training and validation splits with recorded.truth = "training", else
    // the test split, which is then dealt first.
    std::stable_partition(order.begin(), order.end(),
                          [&](int r) { return set.recording_has_truth(r); });
    if (recorded.truth_for_training) {
      recorded.training = deal(0, splits.training);
      recorded.validation = deal(training, splits.validation);
      recorded.test = deal(training + validation, splits.test);
    } else {
      const auto test = static_cast<std::size_t>(splits.test);
      recorded.test = deal(0, splits.test);
      recorded.training = deal(test, splits.training);
      recorded.validation = deal(test + training, splits.validation);
    }
  }
  // The trainers learn from truth only where every training and validation window has it.
  recorded.training_has_truth = recorded.truth_for_training;
  for (const std::vector<int>* split : {&recorded.training, &recorded.validation}) {
    for (const int r : *split) recorded.training_has_truth &= set.recording_has_truth(r);
  }
}

TrackSet recorded_split(const Regime& regime, Split split, int count) {
  const Recorded& recorded = *regime.recorded;
  const std::vector<std::size_t> windows = windows_of(recorded, split);
  const std::string key = "splits." + std::string(to_string(split));
  require(count <= static_cast<int>(windows.size()), key,
          "asks for " + std::to_string(count) + " tracks; the recorded split holds " +
              std::to_string(windows.size()));
  TrackSet set;
  set.regime = regime.name;
  set.split = split;
  set.seed = regime.splits.seed;
  set.sample_period = regime.sample_period;
  set.scans = regime.scans;
  set.recorded = true;
  // Truth for evaluation only never reaches a training or validation split.
  const bool truth_allowed = split == Split::kTest || recorded.truth_for_training;
  set.recording_names = recorded.set->recording_names;
  const std::size_t n = count >= 0 ? static_cast<std::size_t>(count) : windows.size();
  std::size_t with_truth = 0;
  for (std::size_t i = 0; i < n; ++i) {
    Track track = recorded.set->tracks[windows[i]];
    track.noise = regime.sensor.noise;
    const bool truth = truth_allowed && recorded.set->track_has_truth(windows[i]);
    if (!truth) track.truth.setConstant(std::numeric_limits<double>::quiet_NaN());
    with_truth += truth ? 1 : 0;
    set.tracks.push_back(std::move(track));
    set.recording.push_back(recorded.set->recording[windows[i]]);
  }
  set.has_truth = n > 0 && with_truth == n;
  if (with_truth > 0 && with_truth < n) {  // partial truth in this split: the set's own flags
    set.recording_truth = recorded.set->recording_truth;
  }
  return set;
}

int recorded_split_size(const Regime& regime, Split split) {
  return static_cast<int>(windows_of(*regime.recorded, split).size());
}

double recorded_max_range(const TrackSet& set) {
  double range = 0.0;
  for (const Track& track : set.tracks) {
    for (Eigen::Index k = 0; k < track.plots.rows(); ++k) {
      if (std::isfinite(track.plots(k, 0))) range = std::max(range, track.plots(k, 0));
    }
  }
  return range;
}

Track recorded_track(const Regime& regime, Split split, int index) {
  const std::vector<std::size_t> windows = windows_of(*regime.recorded, split);
  require(index >= 0 && static_cast<std::size_t>(index) < windows.size(),
          "splits." + std::string(to_string(split)),
          "has no track " + std::to_string(index) + " (the recorded split holds " +
              std::to_string(windows.size()) + ")");
  Track track = regime.recorded->set->tracks[windows[static_cast<std::size_t>(index)]];
  track.noise = regime.sensor.noise;
  const std::size_t window = windows[static_cast<std::size_t>(index)];
  if ((split != Split::kTest && !regime.recorded->truth_for_training) ||
      !regime.recorded->set->track_has_truth(window)) {
    track.truth.setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  return track;
}

}  // namespace imm::datasets
