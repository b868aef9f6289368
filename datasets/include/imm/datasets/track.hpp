// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Tracks drawn from a regime (imm/datasets/regime.hpp): the truth, simulated with the runtime's
/// own CV model with the noise switched on — x(k+1) = F x(k) + G (u(k) + w(k)) (seed 000 eq. 1),
/// an exact coordinated turn where the program turns, a half-cosine lateral offset added on top
/// during lane changes — and the sensor's plots.
///
/// A track first fixes its maneuver program (start, commanded accelerations u(k), turn rates,
/// lane changes) from its own stream, then draws the noise scan by scan: per scan the plot noise,
/// then the process noise. So track i of a split depends only on (regime, split, seed, i), and a
/// scripted regime's noise sequence is the one of `derive_seed(seed, i)` alone.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "imm/datasets/regime.hpp"

namespace imm::datasets {

struct Track {
  /// scans × 6: x, vx, ax, y, vy, ay. The acceleration is the commanded one over the transition
  /// that starts at the scan (constant accelerations and the turn's centripetal one) plus the lane
  /// change's; the white process noise is not in it.
  Eigen::MatrixXd truth;
  Eigen::MatrixXd plots;  ///< scans × 2: Cartesian (x, y), polar (range, azimuth), range sensor
  /// Per scan: whether a maneuver acts on the transition that starts there.
  std::vector<bool> maneuvering;
  int case_index = 0;
  SensorNoise noise;  ///< what the plots were drawn with
  std::uint64_t seed = 0;
};

/// The tracks of one split.
struct TrackSet {
  std::string regime;  ///< name
  Split split = Split::kTest;
  std::uint64_t seed = 0;  ///< test: the test seed; otherwise splits.seed
  double sample_period = 1.0;
  int scans = 0;
  std::vector<Track> tracks;
  /// Recorded sets (imm/datasets/recorded.hpp): each track's recording (an index into
  /// `recording_names`; a recording's windows share it), and whether every track has its truth
  /// (without it, a track's truth is NaN and only the plots may be used).
  bool recorded = false;
  bool has_truth = true;
  std::vector<int> recording;
  std::vector<std::string> recording_names;
  /// A recorded set with truth for some recordings only (partial truth): per recording, whether it
  /// has its truth (has_truth is then false). Empty when every recording has it or none does.
  std::vector<bool> recording_truth;

  /// Whether recording `r` has its truth: has_truth, or its entry of recording_truth.
  [[nodiscard]] bool recording_has_truth(int r) const {
    return recording_truth.empty() ? has_truth : recording_truth.at(static_cast<std::size_t>(r));
  }
  /// Whether track `index` carries its truth (its recording's, or has_truth for a drawn set).
  [[nodiscard]] bool track_has_truth(std::size_t index) const {
    return recording_truth.empty() ? has_truth : recording_has_truth(recording.at(index));
  }

  /// SHA-256 over the shapes and bytes of every truth and plot matrix.
  [[nodiscard]] std::string digest() const;
};

/// Track `index` of a split (test: of the test seed `seed`).
[[nodiscard]] Track draw_track(const Regime& regime, Split split, int index, std::uint64_t seed);

/// `count` tracks of a split (−1: the regime's split size); InvalidParameter("count") above
/// kMaxSplitTracks.
[[nodiscard]] TrackSet draw_split(const Regime& regime, Split split, std::uint64_t seed,
                                  int count = -1);

/// Calibration samples of a regime's range sensor: obstacles uniform in the calibration box,
/// measured through the sensor with the calibration noise (what a TSK model is fitted on).
[[nodiscard]] RangeSensorData draw_calibration(const Sensor& sensor, std::uint64_t seed);

/// Column helpers for a track's truth.
inline Eigen::Vector2d position_at(const Track& track, Eigen::Index scan) {
  return {track.truth(scan, 0), track.truth(scan, 3)};
}
inline Eigen::Vector2d velocity_at(const Track& track, Eigen::Index scan) {
  return {track.truth(scan, 1), track.truth(scan, 4)};
}
inline Eigen::Vector2d acceleration_at(const Track& track, Eigen::Index scan) {
  return {track.truth(scan, 2), track.truth(scan, 5)};
}

}  // namespace imm::datasets
