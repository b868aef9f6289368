// SPDX-License-Identifier: Apache-2.0
#include "imm/datasets/regime_file.hpp"

#include <cmath>
#include <numbers>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/range_sensor_file.hpp"
#include "imm/datasets/recorded.hpp"
#include "imm/datasets/sampled_sensor.hpp"
#include "imm/datasets/sensor_estimate.hpp"
#include "imm/datasets/sha256.hpp"

namespace imm::datasets {
namespace {

using support::ConfigDocument;
using support::ConfigError;
using support::ConfigTable;

/// A named choice of a fixed set, or a ConfigError listing them.
template <class Enum, std::size_t N>
Enum choice(const ConfigTable& table, std::string_view key, const std::array<Enum, N>& options) {
  const std::string text = table.text(key);
  std::string expected;
  for (Enum option : options) {
    if (text == datasets::to_string(option)) return option;
    expected += (expected.empty() ? "" : ", ") + std::string(datasets::to_string(option));
  }
  table.fail(key, "unknown value '" + text + "' (expected " + expected + ")");
}

/// A number (fixed) or [min, max], times `scale`; `<key>_scale = "log"` makes it log-uniform.
Interval interval(const ConfigTable& table, const std::string& key, double scale = 1.0) {
  Interval result;
  if (table.is_array(key)) {
    const Eigen::VectorXd range = table.reals(key, 2);
    result.min = range(0) * scale;
    result.max = range(1) * scale;
  } else {
    result.min = result.max = table.real(key) * scale;
  }
  const std::string scale_key = key + "_scale";
  if (table.has(scale_key)) {
    const std::string kind = table.text(scale_key);
    if (kind != "log" && kind != "linear") {
      table.fail(scale_key, "unknown scale '" + kind + "' (expected linear or log)");
    }
    result.log = kind == "log";
  }
  return result;
}

Interval interval_or(const ConfigTable& table, const std::string& key, Interval fallback,
                     double scale = 1.0) {
  return table.has(key) ? interval(table, key, scale) : fallback;
}

datasets::Start start_from(const ConfigTable& table) {
  datasets::Start start;
  start.fixed = table.has("position") || table.has("velocity");
  if (start.fixed) {
    start.position = table.reals("position", 2);
    start.velocity = table.reals("velocity", 2);
    for (const char* key :
         {"range", "bearing_deg", "speed", "heading", "heading_deg", "heading_offset_deg"}) {
      if (table.has(key)) table.fail(key, "a fixed start (position, velocity) takes no intervals");
    }
    return start;
  }
  start.range = interval(table, "range");
  start.bearing =
      interval_or(table, "bearing_deg", {0.0, 2.0 * std::numbers::pi}, kRadiansPerDegree);
  start.speed = interval(table, "speed");
  const std::string heading = table.text_or("heading", "absolute");
  if (heading == "inbound") {
    start.inbound = true;
    start.heading = interval_or(table, "heading_offset_deg", {0.0, 0.0}, kRadiansPerDegree);
  } else if (heading == "absolute") {
    start.heading =
        interval_or(table, "heading_deg", {0.0, 2.0 * std::numbers::pi}, kRadiansPerDegree);
  } else {
    table.fail("heading", "unknown heading '" + heading + "' (expected inbound or absolute)");
  }
  return start;
}

/// The plot-noise keys of [sensor] (or a case's override, when any is present).
std::optional<datasets::SensorNoise> noise_from(const ConfigTable& table, SensorKind kind,
                                                const datasets::SensorNoise& fallback) {
  datasets::SensorNoise noise = fallback;
  bool any = false;
  if (kind != SensorKind::kRangeSensor && table.has("sigma") && !table.is_array("sigma") &&
      table.text("sigma") == "estimate") {
    noise.sigma.setConstant(std::numeric_limits<double>::quiet_NaN());
    return noise;  // learned from a recorded regime's plots (sensor_from checks where)
  }
  if (kind == SensorKind::kPolar) {
    if (table.has("range_sigma")) noise.sigma(0) = table.real("range_sigma"), any = true;
    if (table.has("azimuth_sigma_deg")) {
      noise.sigma(1) = table.real("azimuth_sigma_deg") * kRadiansPerDegree;
      any = true;
    }
  } else {
    if (table.has("sigma")) noise.sigma = table.reals("sigma", 2), any = true;
    if (table.has("correlation")) noise.correlation = table.real("correlation"), any = true;
  }
  if (!any) return std::nullopt;
  return noise;
}

datasets::Sensor sensor_from(const ConfigTable& table) {
  datasets::Sensor sensor;
  sensor.kind =
      choice(table, "kind",
             std::array{SensorKind::kCartesian, SensorKind::kPolar, SensorKind::kRangeSensor});
  const auto noise = noise_from(table, sensor.kind, sensor.noise);
  if (!noise) {
    table.fail(sensor.kind == SensorKind::kPolar ? "range_sigma" : "sigma",
               "the sensor's plot noise is missing");
  }
  sensor.noise = *noise;
  sensor.estimate_sigma = std::isnan(sensor.noise.sigma(0));
  if (sensor.estimate_sigma && sensor.kind == SensorKind::kRangeSensor) {
    table.fail("sigma", "\"estimate\" is for a Cartesian or polar sensor's plots");
  }
  if (sensor.estimate_sigma && (table.has("range_sigma") || table.has("azimuth_sigma_deg"))) {
    table.fail("sigma",
               "\"estimate\" learns both σ_r and σ_θ; range_sigma and "
               "azimuth_sigma_deg go without it");
  }
  if (sensor.kind == SensorKind::kPolar) {
    if (table.has("position")) sensor.position = table.reals("position", 2);
    return sensor;
  }
  if (sensor.kind != SensorKind::kRangeSensor) return sensor;
  if (table.has("samples")) {
    sensor.samples_file = table.text("samples");
    for (const char* key : {"knee", "softness"}) {
      if (table.has(key)) table.fail(key, "a sampled sensor takes no distortion parameters");
    }
    datasets::RangeSensorData data;
    try {
      data = datasets::read_sensor_samples(sensor.samples_file);
      sensor.sampled =
          std::make_shared<const datasets::SampledSensor>(data.positions, data.outputs);
    } catch (const std::exception& error) {
      table.fail("samples", error.what());
    }
    sensor.samples_digest = datasets::digest(data);
    sensor.calibration.lower = sensor.sampled->lower();
    sensor.calibration.upper = sensor.sampled->upper();
  } else {
    sensor.distortion.knee = table.real("knee");
    sensor.distortion.softness = table.real("softness");
  }
  if (const auto calibration = table.table("calibration")) {
    datasets::SensorCalibration& c = sensor.calibration;
    c.samples = calibration->count_or("samples", c.samples);
    if (calibration->has("box")) {
      const Eigen::MatrixXd box = calibration->matrix("box", 2, 2);
      c.lower = box.row(0).transpose();
      c.upper = box.row(1).transpose();
    }
    c.noise_sigma = calibration->real_or("noise_sigma", c.noise_sigma);
  }
  return sensor;
}

datasets::MenuEntry menu_entry_from(const ConfigTable& table) {
  datasets::MenuEntry e;
  e.kind = choice(table, "kind",
                  std::array{SegmentKind::kConstantVelocity, SegmentKind::kConstantAcceleration,
                             SegmentKind::kTurn, SegmentKind::kZigzag, SegmentKind::kLaneChange});
  e.probability = table.real("probability");
  if (e.kind != SegmentKind::kZigzag) e.duration = interval(table, "duration");
  switch (e.kind) {
    case SegmentKind::kConstantAcceleration:
      e.magnitude = interval(table, "magnitude");
      e.direction = choice(
          table, "direction",
          std::array{Direction::kAlong, Direction::kLateral, Direction::kAny, Direction::kAxis});
      break;
    case SegmentKind::kTurn:
      e.rate = interval(table, "rate_deg", kRadiansPerDegree);
      break;
    case SegmentKind::kZigzag: {
      e.magnitude = interval(table, "magnitude");
      e.quarter = interval(table, "quarter");
      const Eigen::VectorXd periods = table.reals("periods", 2);
      if (periods(0) != std::floor(periods(0)) || periods(1) != std::floor(periods(1)) ||
          !(periods(0) >= 1.0 && periods(1) >= periods(0) && periods(1) <= 1000.0)) {
        table.fail("periods", "must be whole numbers [min, max] with 1 ≤ min ≤ max ≤ 1000");
      }
      e.min_periods = static_cast<int>(periods(0));
      e.max_periods = static_cast<int>(periods(1));
      break;
    }
    case SegmentKind::kLaneChange:
      e.magnitude = interval(table, "offset");
      break;
    case SegmentKind::kConstantVelocity:
      break;
  }
  return e;
}

datasets::ScriptedSegment segment_from(const ConfigTable& table) {
  datasets::ScriptedSegment s;
  s.kind = choice(
      table, "kind",
      std::array{SegmentKind::kConstantAcceleration, SegmentKind::kTurn, SegmentKind::kZigzag,
                 SegmentKind::kLaneChange, SegmentKind::kConstantVelocity});
  s.start = table.real("start");
  if (s.kind == SegmentKind::kZigzag) {
    s.quarter = table.real("quarter");
    const Eigen::VectorXd amplitudes = table.reals("amplitudes");
    s.amplitudes.assign(amplitudes.data(), amplitudes.data() + amplitudes.size());
    return s;
  }
  s.end = table.real("end");
  switch (s.kind) {
    case SegmentKind::kConstantAcceleration:
      s.acceleration = table.reals("acceleration", 2);
      break;
    case SegmentKind::kTurn:
      s.rate = table.real("rate_deg") * kRadiansPerDegree;
      break;
    case SegmentKind::kLaneChange:
      s.offset = table.real("offset");
      break;
    default:
      break;
  }
  return s;
}

Units units_from(const ConfigTable& root) {
  const std::string units = root.text("units");
  if (units != "m" && units != "km") {
    root.fail("units", "unknown units '" + units + "' (expected m or km)");
  }
  return units == "m" ? datasets::Units::kMetres : datasets::Units::kKilometres;
}

/// [scene], each key defaulting to SceneSpec's.
datasets::SceneSpec scene_from(const ConfigTable& root) {
  datasets::SceneSpec scene;
  if (const auto table = root.table("scene")) {
    scene.targets = table->count_or("targets", scene.targets);
    scene.detection_probability =
        table->real_or("detection_probability", scene.detection_probability);
    scene.clutter_per_scan = table->real_or("clutter_per_scan", scene.clutter_per_scan);
  }
  return scene;
}

/// [splits], each key defaulting to `defaults`'.
Splits splits_from(const ConfigTable& root, Splits defaults) {
  if (const auto splits = root.table("splits")) {
    defaults.training = splits->count_or("training", defaults.training);
    defaults.validation = splits->count_or("validation", defaults.validation);
    defaults.test = splits->count_or("test", defaults.test);
    defaults.seed = splits->seed_or("seed", defaults.seed);
  }
  return defaults;
}

void published_from(const ConfigTable& root, RegimeFile& file) {
  for (const ConfigTable& table : root.tables("published")) {
    PublishedFigure figure;
    figure.source = table.text("source");
    figure.filter = table.text("filter");
    figure.case_name = table.text_or("case", "");
    for (const std::string& key : table.keys()) {
      if (key == "source" || key == "filter" || key == "case") continue;
      figure.metric = key;
      figure.value = table.real(key);
      file.published.push_back(figure);
    }
  }
}

/// The text, the digest (of the text, the sensor's samples and the recorded set) and validation.
void finish(datasets::Regime& r, const std::string& text) {
  r.text = text;
  datasets::Sha256 hash;
  hash.update(text);
  hash.update(r.sensor.samples_digest);
  if (r.recorded) hash.update(r.recorded->digest);
  r.digest = hash.hex_digest();
  r.validate();
}

RegimeFile recorded_regime_from(const ConfigTable& root, const ConfigTable& table,
                                const std::string& text);

RegimeFile regime_from(const ConfigTable& root, const std::string& text) {
  if (const auto recorded = root.table("recorded"))
    return recorded_regime_from(root, *recorded, text);
  RegimeFile file;
  datasets::Regime& r = file.regime;
  r.name = root.text("name");
  r.units = units_from(root);
  r.sample_period = root.real("sample_period");
  r.scans = root.count("scans");
  r.process_noise_sigma = root.real_or("process_noise_sigma", 0.0);
  const auto sensor = root.table("sensor");
  if (!sensor) root.fail("sensor", "missing");
  r.sensor = sensor_from(*sensor);
  if (r.sensor.estimate_sigma) sensor->fail("sigma", "\"estimate\" needs a [recorded] regime");
  if (const auto start = root.table("start")) {
    r.start = start_from(*start);
  } else if (!root.has("cases")) {
    root.fail("start", "missing");
  } else {
    r.start.fixed = true;  // every case brings its own start
  }
  for (const ConfigTable& entry : root.tables("maneuvers"))
    r.menu.push_back(menu_entry_from(entry));
  for (const ConfigTable& table : root.tables("cases")) {
    datasets::ScriptedCase c;
    c.name = table.text("name");
    if (const auto start = table.table("start")) c.start = start_from(*start);
    c.noise = noise_from(table, r.sensor.kind, r.sensor.noise);
    for (const ConfigTable& segment : table.tables("segments")) {
      c.segments.push_back(segment_from(segment));
    }
    r.cases.push_back(std::move(c));
  }
  if (!root.has("start")) {
    for (std::size_t i = 0; i < r.cases.size(); ++i) {
      if (!r.cases[i].start) {
        root.fail("cases[" + std::to_string(i) + "].start",
                  "without a regime-wide [start] every case needs its own");
      }
    }
  }
  r.splits = splits_from(root, r.splits);
  r.scene = scene_from(root);
  published_from(root, file);
  finish(r, text);
  return file;
}

RegimeFile recorded_regime_from(const ConfigTable& root, const ConfigTable& table,
                                const std::string& text) {
  for (const char* key : {"start", "maneuvers", "cases", "process_noise_sigma"}) {
    if (root.has(key)) root.fail(key, "a recorded regime's tracks come from [recorded].set");
  }
  RegimeFile file;
  datasets::Regime& r = file.regime;
  r.name = root.text("name");
  r.units = units_from(root);
  auto recorded = std::make_shared<Recorded>();
  recorded->file = table.text("set");
  TrackSetFile set;
  try {
    set = read_track_set(recorded->file);
  } catch (const std::exception& error) {
    table.fail("set", error.what());
  }
  if (!set.set.recorded) {
    table.fail("set", "'" + recorded->file + "' holds drawn tracks, not imported recordings");
  }
  if (set.units != to_string(r.units)) {
    root.fail("units", "the recorded set '" + recorded->file + "' is in " + set.units);
  }
  r.sample_period = root.real_or("sample_period", set.set.sample_period);
  if (std::abs(r.sample_period - set.set.sample_period) > 1e-9 * set.set.sample_period) {
    root.fail("sample_period",
              "the recorded set was imported at " + std::to_string(set.set.sample_period) + " s");
  }
  r.scans = root.count_or("scans", set.set.scans);
  if (r.scans != set.set.scans) {
    root.fail("scans", "the recorded set's windows have " + std::to_string(set.set.scans));
  }
  const auto sensor = root.table("sensor");
  if (!sensor) root.fail("sensor", "missing");
  r.sensor = sensor_from(*sensor);
  if (set.sensor != to_string(r.sensor.kind)) {
    sensor->fail("kind", "the recorded set's plots are " + set.sensor);
  }
  const std::string truth = table.text_or("truth", "evaluation");
  if (truth != "evaluation" && truth != "training") {
    table.fail("truth", "unknown use '" + truth + "' (expected evaluation or training)");
  }
  recorded->truth_for_training = truth == "training";
  if (recorded->truth_for_training && !set.set.has_truth && set.set.recording_truth.empty()) {
    table.fail("truth", "the recorded set has no truth to train on");
  }
  if (table.has("acceleration")) {
    const Eigen::VectorXd a = table.reals("acceleration", 2);
    if (!(a(0) > 0.0 && a(1) >= a(0) && a(1) <= limits::kAcceleration.max)) {
      table.fail("acceleration", "must be [smallest, largest] with 0 < smallest ≤ largest ≤ " +
                                     std::to_string(limits::kAcceleration.max));
    }
    recorded->min_acceleration = a(0);
    recorded->max_acceleration = a(1);
  }
  recorded->digest = set.digest;
  const int recordings = static_cast<int>(set.set.recording_names.size());
  // Default splits: 60 % of the recordings for training, 20 % for validation, the rest for test.
  r.splits.training = std::max(1, (3 * recordings) / 5);
  r.splits.validation = std::max(1, recordings / 5);
  r.splits.test = std::max(1, recordings - r.splits.training - r.splits.validation);
  r.splits = splits_from(root, r.splits);
  r.scene = scene_from(root);
  if (r.splits.training + r.splits.validation + r.splits.test > recordings) {
    root.fail("splits",
              "training + validation + test = " +
                  std::to_string(r.splits.training + r.splits.validation + r.splits.test) +
                  " recordings; the set has " + std::to_string(recordings));
  }
  recorded->set = std::make_shared<const TrackSet>(std::move(set.set));
  assign_recorded_splits(*recorded, r.splits);
  r.recorded = recorded;
  published_from(root, file);
  if (r.sensor.estimate_sigma && r.splits.training < 1) {
    root.fail("splits.training", "sigma = \"estimate\" learns σ from the training recordings");
  }
  // The fit is a Cartesian CV IMM's: a polar or range sensor's regime states its manoeuvres'
  // scale (recorded.acceleration) where a trainer needs it, and so does a regime with no
  // training recordings.
  const bool estimate_acceleration = !table.has("acceleration") &&
                                     r.sensor.kind == SensorKind::kCartesian &&
                                     r.splits.training > 0;
  if (r.sensor.estimate_sigma || estimate_acceleration) {
    // One fit of the training split's plots gives the σ to estimate and the manoeuvres' scale:
    // the manoeuvring mode's √q₂ (the quiet mode's √q₁ the smallest, at least 10⁻³ of it).
    const TrackSet training = recorded_split(r, Split::kTraining);
    if (r.sensor.estimate_sigma && r.sensor.kind == SensorKind::kPolar) {  // σ_r, σ_θ apart
      const PolarSigmaFit polar = fit_polar_sigma(training);
      r.sensor.noise.sigma << polar.range.model.sigma, polar.azimuth.model.sigma;
    }
    const PlotSigmaFit fit =
        r.sensor.kind == SensorKind::kCartesian ? fit_plot_sigma(training) : PlotSigmaFit{};
    if (r.sensor.estimate_sigma && r.sensor.kind == SensorKind::kCartesian) {
      r.sensor.noise.sigma.setConstant(fit.model.sigma);
    }
    if (estimate_acceleration) {
      recorded->max_acceleration = std::sqrt(fit.model.manoeuvre_noise);
      recorded->min_acceleration =
          std::max(std::sqrt(fit.model.quiet_noise), 1e-3 * recorded->max_acceleration);
      recorded->acceleration_estimated = true;
    }
  }
  finish(r, text);
  return file;
}

}  // namespace

const PublishedFigure* RegimeFile::find(const std::string& filter, const std::string& case_name,
                                        const std::string& metric) const {
  for (const PublishedFigure& figure : published) {
    if (figure.filter == filter && figure.case_name == case_name && figure.metric == metric) {
      return &figure;
    }
  }
  return nullptr;
}

RegimeFile parse_regime(const std::string& text, const std::string& name) {
  const auto document = ConfigDocument::parse(text, name);
  RegimeFile file = document->load_checked([&] { return regime_from(document->root(), text); });
  file.regime.file = name;
  return file;
}

RegimeFile load_regime(const std::filesystem::path& path) {
  const auto document = ConfigDocument::load(path);
  RegimeFile file =
      document->load_checked([&] { return regime_from(document->root(), document->text()); });
  file.regime.file = path.string();
  return file;
}

}  // namespace imm::datasets
