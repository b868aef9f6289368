// SPDX-License-Identifier: Apache-2.0
#pragma once
/// A reference multi-target tracker built only on the runtime's public API: one filter per track
/// from a model file (imm::FilterMaker), global nearest neighbour association with a χ² gate,
/// two-point initiation, M-of-N confirmation and deletion after misses. Per scan:
///   1. every track predicts (TrackFilter::predict: the first half of its cycle);
///   2. each (track, plot) pair inside the gate costs its squared distance d² to the track's
///      collapsed predicted plot (TrackFilter::candidate_distance); leaving a track or a plot out
///      costs gate/2, so any pair inside the gate may be made and the total d² is least
///      (gated_assignment);
///   3. an assigned track updates with its plot, the others miss;
///   4. a tentative track with M hits within its first N scans is confirmed, one that cannot get
///      there is deleted; a track that misses `misses_to_delete` scans in a row is deleted;
///   5. each plot left over is paired with the nearest plot left over from the scan before within
///      the reach of `max_speed` — a new tentative track (imm::two_point_start) — or waits for
///      the next scan.
/// The filter must split its cycle (TrackFilter::has_split_cycle: every kind but a wIMM that fuses
/// the azimuth); the gate is the prediction without the plot, and a learned kind's candidate is
/// scored by its trial update.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "imm/load.hpp"

namespace imm::evaluation {

/// How the tracker associates, starts, confirms and ends tracks.
struct GnnSettings {
  double gate = 9.21;        ///< χ²(2) gate on d² (9.21: 99 %)
  int confirm_hits = 3;      ///< M: hits (the two starting plots included) …
  int confirm_scans = 4;     ///< … within a tentative track's first N scans
  int misses_to_delete = 3;  ///< consecutive misses that end a confirmed track
  double max_speed = 0.0;    ///< a new target's largest speed (length/s); must be > 0
  /// Throws InvalidParameter naming the field.
  void validate() const;
};

/// One track's estimate at the last scan.
struct GnnEstimate {
  int id = 0;                  ///< the track's number, in order of starting, never reused
  bool confirmed = false;      ///< M of N reached
  Eigen::Vector2d position;    ///< x, y
  Eigen::VectorXd mean;        ///< the filter's whole state
  Eigen::MatrixXd covariance;  ///< its covariance
};

/// The tracker (see the file comment).
class GnnTracker {
 public:
  /// Throws InvalidParameter naming the field of invalid settings, or "model" for a filter that
  /// does not split its cycle.
  GnnTracker(FilterMaker maker, GnnSettings settings);

  /// One scan's plots, in any order (an unusable one is left out). Scans must increase; a scan
  /// that does not is refused with std::invalid_argument and changes nothing.
  void process(std::int64_t scan, std::span<const Eigen::Vector2d> plots);

  /// The tracks' estimates (only the confirmed ones unless `tentative`), by id.
  [[nodiscard]] std::vector<GnnEstimate> estimates(bool tentative = false) const;
  /// Tracks started so far.
  [[nodiscard]] int tracks_started() const { return next_id_; }

 private:
  struct Track {
    int id = 0;
    std::unique_ptr<TrackFilter> filter;
    int hits = 0, age = 0, misses = 0;
    bool confirmed = false;
  };
  struct Seed {
    std::int64_t scan = 0;
    Eigen::Vector2d z;
    Eigen::Vector2d position;
  };

  void start_tracks(std::int64_t scan, std::span<const Eigen::Vector2d> plots,
                    const std::vector<char>& used);
  [[nodiscard]] Eigen::Vector2d position_of(const Eigen::Vector2d& z) const;

  FilterMaker maker_;
  GnnSettings settings_;
  std::vector<Track> tracks_;
  std::vector<Seed> seeds_;
  std::int64_t last_scan_ = -1;
  bool started_ = false;
  int next_id_ = 0;
};

}  // namespace imm::evaluation
