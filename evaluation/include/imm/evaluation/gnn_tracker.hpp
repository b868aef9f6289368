// SPDX-License-Identifier: Apache-2.0
#pragma once
/// A reference multi-target tracker built only on the runtime's public API: one filter per track
/// from a model file (imm::FilterMaker), global nearest neighbour association with a χ² gate,
/// two-point initiation, confirmation (M of N, or the track's likelihood ratio against the clutter
/// density) and deletion after misses. Per scan:
///   1. every track predicts (TrackFilter::predict: the first half of its cycle);
///   2. each (track, plot) pair inside the gate costs its squared distance d² to the track's
///      collapsed predicted plot (TrackFilter::candidate_distance); leaving a track or a plot out
///      costs gate/2, so any pair inside the gate may be made and the total d² is least
///      (gated_assignment);
///   3. an assigned track updates with its plot, the others miss;
///   4. a tentative track with M hits within its first N scans is confirmed, one that cannot get
///      there is deleted; a track that misses `misses_to_delete` scans in a row is deleted. With a
///      clutter density β > 0 a tentative track is instead scored by a sequential probability
///      ratio test (Blackman & Popoli, "Design and Analysis of Modern Tracking Systems", 1999,
///      §6.2): its log-likelihood ratio gains log(Pd) + log p(z | track) − log β per plot, with
///      p(z | track) the filter's own predictive density of the plot
///      (TrackFilter::candidate_log_likelihood), and log(1 − Pd·P_G) per miss; it is confirmed
///      above log((1 − β_T)/α_T) and deleted below log(β_T/(1 − α_T)). A filter that predicts
///      widely is charged for it: more clutter falls in its gate, but each plot weighs less;
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
  /// False plots per unit of plot space per scan (per m² for Cartesian plots, per m·rad for polar
  /// ones); > 0: confirm by the likelihood ratio (above) instead of M of N.
  double clutter_density = 0.0;
  double detection_probability = 0.9;  ///< Pd in the likelihood ratio
  double false_track_rate = 1e-3;      ///< α_T: a false track's chance to be confirmed
  double true_track_loss = 0.1;        ///< β_T: a true track's chance to be deleted tentative
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
    double score = 0.0;  // the log-likelihood ratio (with a clutter density)
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
