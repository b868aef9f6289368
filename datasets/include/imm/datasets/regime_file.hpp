// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The TOML form of a regime (configs/regimes/*.toml; imm/datasets/regime.hpp says what a regime
/// is). Every key, with its unit (the regime's `units` for lengths, s for times, degrees for
/// angles):
///
///   name = "agile_air";  units = "m" | "km";  sample_period = 1.0;  scans = 200
///   process_noise_sigma = 0.5                    truth's white acceleration per axis
///   [sensor]  kind = "cartesian"  sigma = [σx, σy]  correlation = 0.0
///             kind = "polar"      range_sigma = σ_r  azimuth_sigma_deg = σ_θ  position = [x, y]
///             kind = "range_sensor"  sigma = [σ₁, σ₂]  knee = 40.0  softness = 30.0
///                                    (or samples = "file.csv|.h5": the sensor these came from)
///             [sensor.calibration]  box = [[ξ_min, η_min], [ξ_max, η_max]]  samples = 8000
///                                   noise_sigma = 0.05        (range sensor: what a TSK fits)
///   [start]   position = [x, y]  velocity = [vx, vy]          a fixed start, or drawn:
///             range = [a, b]  bearing_deg = [a, b]  speed = [a, b]
///             heading = "inbound" (heading_offset_deg = [a, b]) | "absolute" (heading_deg)
///   [[maneuvers]]  kind = "cv" | "ca" | "turn" | "zigzag" | "lane_change"
///                  probability = p  duration = [a, b] s
///                  ca: magnitude = [a, b]  direction = "along" | "lateral" | "any" | "axis"
///                  turn: rate_deg = [a, b]   zigzag: magnitude, quarter = [a, b] s,
///                  periods = [a, b]          lane_change: offset = [a, b]
///   [[cases]]  name = "..."  (noise: sigma / range_sigma / azimuth_sigma_deg / correlation)
///              [cases.start] …   [[cases.segments]] kind, start, end (s) and
///              ca: acceleration = [ax, ay]; turn: rate_deg; zigzag: quarter, amplitudes = [...];
///              lane_change: offset
///   [splits]  training = 12  validation = 6  test = 100  seed = 1
///   [scene]  targets = 3  detection_probability = 0.9  clutter_per_scan = 10.0
///            several targets at once among Poisson clutter (scene.hpp): what imm-data scenes
///            and imm-eval multi-target draw by default (these values when absent)
///   [recorded]  set = "data/recorded/x.h5"       a recorded regime (imm/datasets/recorded.hpp):
///               truth = "evaluation" | "training"  its tracks come from an imported set instead
///               acceleration = [min, max]          of start/maneuvers/cases/process_noise_sigma
///                                                  (refused beside it); [splits] counts whole
///               recordings (default 60/20/20 %, test may be 0); sample_period and scans default
///               to the set's; [sensor] sigma = "estimate" (Cartesian) learns σ from the plots, as
///               an absent acceleration is (imm/datasets/sensor_estimate.hpp)
///   [[published]]  source = "..."  filter = "..."  case = "..."  <metric> = value …
///
/// An interval is a number (fixed) or [min, max]; `<key>_scale = "log"` draws it log-uniformly.
/// Errors are ConfigErrors naming the file and the key.

#include <filesystem>
#include <string>
#include <vector>

#include "imm/datasets/regime.hpp"
#include "imm/support/config.hpp"

namespace imm::datasets {

/// A figure a paper published for this regime (reported beside ours; never used to gate).
struct PublishedFigure {
  std::string source, filter, case_name, metric;
  double value = 0.0;
};

struct RegimeFile {
  datasets::Regime regime;
  std::vector<PublishedFigure> published;

  /// The published figure for (filter, case, metric), if the file has one.
  [[nodiscard]] const PublishedFigure* find(const std::string& filter, const std::string& case_name,
                                            const std::string& metric) const;
};

/// Reads and validates a regime file.
[[nodiscard]] RegimeFile load_regime(const std::filesystem::path& path);
/// The same from text (a regime recorded in a model file); `name` stands for the file in errors.
[[nodiscard]] RegimeFile parse_regime(const std::string& text, const std::string& name);

}  // namespace imm::datasets
