// SPDX-License-Identifier: Apache-2.0
#pragma once
/// A regime: the distribution of tracking situations a model is trained for and evaluated on
/// (configs/regimes/*.toml; imm/datasets/regime_file.hpp reads them). A track is a seeded draw
/// from it; the training, validation and test splits are draws from disjoint seeds.
///
/// What a regime fixes: the unit of length (m or km; time is always s), the sample period, the
/// scans per track, the sensor (Cartesian, polar, or a distorted range sensor given by its
/// distortion or by samples of it), how a target starts (intervals or a fixed state), the truth's
/// white process noise, and the maneuvers — either a menu of random segments (constant velocity,
/// constant acceleration, coordinated turn, zigzag, half-cosine lane change, each with its
/// probability, duration and strength) or a list of scripted cases (the papers' scenarios are
/// scripted; track i of a split follows case i mod cases, so every case gets the same share).
///
/// Directions: a scripted segment's "lateral" or lane change is taken against the track's
/// initial velocity; a random segment's against the noise-free velocity at the segment's start.
/// Azimuths and headings are measured from the y axis (north), positive toward x (east), as the
/// polar measurement model's atan2(x, y).

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "imm/datasets/range_sensor.hpp"

namespace imm::datasets {

/// π / 180 as one double: a regime's angles are written in degrees (the `*_deg` keys) and held in
/// radians, each value times this constant.
inline constexpr double kRadiansPerDegree = std::numbers::pi / 180.0;

class Rng;
class SampledSensor;

enum class Units { kMetres, kKilometres };
enum class SensorKind { kCartesian, kPolar, kRangeSensor };
enum class SegmentKind { kConstantVelocity, kConstantAcceleration, kTurn, kZigzag, kLaneChange };
/// Direction of a random constant acceleration: along or against the velocity, to either side
/// of it, any angle, or along ±x or ±y.
enum class Direction { kAlong, kLateral, kAny, kAxis };

[[nodiscard]] std::string_view to_string(Units units);
[[nodiscard]] std::string_view to_string(SensorKind kind);
[[nodiscard]] std::string_view to_string(SegmentKind kind);
[[nodiscard]] std::string_view to_string(Direction direction);

/// An interval to draw from: uniform, or log-uniform (both ends > 0).
struct Interval {
  double min = 0.0;
  double max = 0.0;
  bool log = false;
  [[nodiscard]] double draw(Rng& rng) const;
  [[nodiscard]] bool operator==(const Interval&) const = default;
};

/// The plots' noise: Cartesian σx, σy and their correlation; polar σ_r, σ_θ (rad); range sensor
/// σ per output.
struct SensorNoise {
  Eigen::Vector2d sigma = Eigen::Vector2d::Ones();
  double correlation = 0.0;
  [[nodiscard]] Eigen::Matrix2d covariance() const;
  [[nodiscard]] bool operator==(const SensorNoise&) const = default;
};

/// How a range sensor is measured for its model: obstacles uniform in a box, measured with noise
/// (what `imm-train tsk` fits; seed 002 §2.2).
struct SensorCalibration {
  int samples = 8000;
  Eigen::Vector2d lower = Eigen::Vector2d(-6.0, 1.0);  ///< ξ, η
  Eigen::Vector2d upper = Eigen::Vector2d(6.0, 100.0);
  double noise_sigma = 0.05;
  [[nodiscard]] bool operator==(const SensorCalibration&) const = default;
};

struct Sensor {
  SensorKind kind = SensorKind::kCartesian;
  SensorNoise noise;
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  ///< polar: the sensor in the regime frame
  /// Range sensor: the true distortion, or — when `sampled` is set — the sensor these samples came
  /// from (a data file named by `samples_file`, digest `samples_digest`).
  RangeDistortion distortion;
  std::shared_ptr<const SampledSensor> sampled;
  std::string samples_file, samples_digest;
  /// A recorded regime's `sigma = "estimate"`: the plot σ (one for both axes) is learned from the
  /// training split's plots, and `noise` holds the estimate once a trainer has made it
  /// (imm/datasets/sensor_estimate.hpp).
  bool estimate_sigma = false;
  SensorCalibration calibration;

  /// The noise-free output of the sensor at a position (range sensor; the others measure the
  /// position itself).
  [[nodiscard]] Eigen::Vector2d response(const Eigen::Vector2d& at) const;
};

/// How a target starts: a fixed state, or drawn — range and bearing from the sensor (polar) or
/// from the origin, speed, and a heading either absolute or off the inbound radial.
struct Start {
  bool fixed = false;
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  ///< fixed
  Eigen::Vector2d velocity = Eigen::Vector2d::Zero();
  Interval range{0.0, 0.0}, bearing{0.0, 0.0}, speed{0.0, 0.0};  ///< bearing in rad
  bool inbound = false;        ///< heading measured off the inbound radial
  Interval heading{0.0, 0.0};  ///< rad
  [[nodiscard]] bool operator==(const Start&) const = default;
};

/// One entry of a random maneuver menu.
struct MenuEntry {
  SegmentKind kind = SegmentKind::kConstantVelocity;
  double probability = 0.0;
  Interval duration{0.0, 0.0};   ///< s (a zigzag lasts 4 · quarter · periods instead)
  Interval magnitude{0.0, 0.0};  ///< |a| (constant acceleration, zigzag), |offset| (lane change)
  Direction direction = Direction::kAny;  ///< constant acceleration
  Interval rate{0.0, 0.0};                ///< |ω|, rad/s (turn)
  Interval quarter{0.0, 0.0};             ///< s (zigzag)
  int min_periods = 1, max_periods = 1;   ///< zigzag
};

/// A scripted segment: transitions k with start ≤ kT < end (s from the track's start).
struct ScriptedSegment {
  SegmentKind kind = SegmentKind::kConstantVelocity;
  double start = 0.0, end = 0.0;
  Eigen::Vector2d acceleration = Eigen::Vector2d::Zero();  ///< constant acceleration
  double rate = 0.0;               ///< turn, rad/s, counter-clockwise positive
  std::vector<double> amplitudes;  ///< zigzag: |a| per period, lateral to the initial velocity
  double quarter = 0.0;            ///< zigzag, s (the zigzag ends at start + 4 quarter periods)
  double offset = 0.0;             ///< lane change: to the left of the initial velocity
};

/// A scripted case: its own segments, and optionally its own start and plot noise.
struct ScriptedCase {
  std::string name;
  std::optional<Start> start;
  std::optional<SensorNoise> noise;
  std::vector<ScriptedSegment> segments;
};

struct TrackSet;

/// A recorded regime's tracks (imm/datasets/recorded.hpp): a track-set file written by
/// `imm-data import`, split into training, validation and test by a seeded shuffle of whole
/// recordings (Splits: counts of recordings; every window of a recording goes with it).
struct Recorded {
  std::string file;  ///< the track-set file, as the regime names it
  std::shared_ptr<const TrackSet> set;
  std::string digest;  ///< the set's data digest (what models record, never the plots)
  /// Truth, where the set has it: for evaluation only (the trainers learn from the plots), or for
  /// training too.
  bool truth_for_training = false;
  /// The manoeuvres' acceleration magnitudes the models are built for, [smallest, largest]:
  /// recorded.acceleration, or — when it is not stated — estimated from the training split's
  /// plots (the √q of a two-mode CV IMM's modes fitted by their predictive likelihood,
  /// sensor_estimate.hpp) for a Cartesian sensor with training recordings; 0 (not known) otherwise.
  double min_acceleration = 0.0, max_acceleration = 0.0;
  bool acceleration_estimated = false;
  /// The recordings of each split, in their shuffled order, and the windows they hold.
  std::vector<int> training, validation, test;
  /// Whether the trainers learn from truth: recorded.truth = "training" and every training and
  /// validation recording has its truth (with partial truth, a split that lacks some is learned
  /// from its plots alone).
  bool training_has_truth = false;
};

/// The most tracks a split holds (a regime's [splits]) and a draw makes at once.
inline constexpr int kMaxSplitTracks = 1'000'000;

struct Splits {
  int training = 12;
  int validation = 6;
  int test = 100;
  std::uint64_t seed = 1;
};

enum class Split { kTraining, kValidation, kTest };
[[nodiscard]] std::string_view to_string(Split split);
/// The value whose to_string is `name`; InvalidParameter(field) listing the names otherwise.
[[nodiscard]] Split split_named(std::string_view name, const std::string& field);
[[nodiscard]] Units units_named(std::string_view name, const std::string& field);
[[nodiscard]] SensorKind sensor_kind_named(std::string_view name, const std::string& field);

/// Several targets at once ([scene]): what imm-data scenes and imm-eval multi-target draw
/// (scene.hpp) unless told otherwise.
struct SceneSpec {
  int targets = 3;                     ///< targets per scene, 1 to 100
  double detection_probability = 0.9;  ///< Pd of every target at every scan, (0, 1]
  double clutter_per_scan = 10.0;      ///< mean false plots per scan over the region, [0, 10⁴]
  /// Throws InvalidParameter naming the key ("scene.targets").
  void validate() const;
};

struct Regime {
  std::string name;
  Units units = Units::kMetres;
  double sample_period = 1.0;        ///< T, s
  int scans = 100;                   ///< per track
  double process_noise_sigma = 0.0;  ///< the truth's white acceleration per axis
  Sensor sensor;
  Start start;
  std::vector<MenuEntry> menu;      ///< random maneuvers (when there are no cases)
  std::vector<ScriptedCase> cases;  ///< scripted maneuvers
  Splits splits;
  /// Several targets at once ([scene]); the defaults of SceneSpec when the file has none.
  SceneSpec scene;
  /// Set for a recorded regime: its tracks come from a recording instead of a generator (there is
  /// no start, maneuver or process noise then).
  std::shared_ptr<const Recorded> recorded;

  std::string file;    ///< where it was read from ("" for one built in code)
  std::string text;    ///< the file's text: what models record
  std::string digest;  ///< SHA-256 of the text (and of the sensor samples, if any)

  /// Throws InvalidParameter naming the field in the file's vocabulary ("start.speed").
  void validate() const;
  [[nodiscard]] bool scripted() const { return !cases.empty(); }
  /// Whether the trainers learn from the truth of the training and validation splits: a drawn
  /// regime, or a recorded one whose every training and validation recording has truth and which
  /// says recorded.truth = "training" (Recorded::training_has_truth). Otherwise from the plots.
  [[nodiscard]] bool trains_from_truth() const { return !recorded || recorded->training_has_truth; }
  /// Cases of the regime (1 for a random one) and their names ("" for a random regime).
  [[nodiscard]] int case_count() const;
  [[nodiscard]] const std::string& case_name(int index) const;
  /// The plot noise of a case.
  [[nodiscard]] const SensorNoise& noise_of(int case_index) const;
  /// Largest and smallest positive commanded acceleration magnitude (turns count at the largest
  /// start speed; lane changes at their peak). 0 when the regime never maneuvers.
  [[nodiscard]] double max_acceleration() const;
  [[nodiscard]] double min_acceleration() const;
  /// Largest start speed.
  [[nodiscard]] double max_speed() const;
  /// A position σ of the plots: Cartesian and range sensor the larger σ, polar the larger of σ_r
  /// and σ_θ at the largest start range.
  [[nodiscard]] double position_sigma() const;
};

/// Seed of track `index` of a split. Test tracks use derive_seed(test_seed, index); training and
/// validation draw from their own streams of splits.seed — disjoint by construction of the
/// streams (the test seed is the evaluation's --seed).
[[nodiscard]] std::uint64_t track_seed(const Regime& regime, Split split, int index,
                                       std::uint64_t test_seed);

/// The number of tracks a split holds.
[[nodiscard]] int split_size(const Regime& regime, Split split);

}  // namespace imm::datasets
