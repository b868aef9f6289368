// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/model_files/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/regime.hpp"
#include "imm/datasets/regime_file.hpp"
#include "imm/datasets/track.hpp"
#include "imm/io/container_file.hpp"
#include "imm/io/model_file.hpp"
#include "imm/model_kinds.hpp"
#include "imm/tracking/tracker.hpp"
#include "imm/trainer/model_files/seal.hpp"
#include "imm/trainer/normalized_errors.hpp"

namespace imm::trainer {
namespace {

// One plot's or one estimate's normalized error and the features its factor comes from.
struct Sample {
  long used = 0;
  double level = 0.0;
  double value = 0.0;  // NIS or position NEES
};

// c_start(u) · c_level(b) moment-matched to value / dimension (see the header), for samples of
// `dimension` 2. Cells with fewer than `min_samples` keep 1.
void fit_tables(const std::vector<Sample>& samples, const CalibrationSettings& settings,
                const CovarianceCalibration& shape, std::vector<double>& start,
                std::vector<double>& level) {
  start.assign(static_cast<std::size_t>(settings.start_entries), 1.0);
  level.assign(shape.edges.size() + 1, 1.0);
  if (samples.empty()) return;
  const auto start_of = [&](const Sample& s) {
    return static_cast<std::size_t>(std::clamp<long>(s.used, 0, settings.start_entries - 1));
  };
  const auto bin_of = [&](const Sample& s) { return static_cast<std::size_t>(shape.bin(s.level)); };
  for (int pass = 0; pass < 4; ++pass) {
    for (const bool fit_start : {true, false}) {
      std::vector<double>& table = fit_start ? start : level;
      std::vector<double> sum(table.size(), 0.0);
      std::vector<long> count(table.size(), 0);
      for (const Sample& s : samples) {
        const std::size_t cell = fit_start ? start_of(s) : bin_of(s);
        sum[cell] += s.value / (fit_start ? level[bin_of(s)] : start[start_of(s)]);
        ++count[cell];
      }
      for (std::size_t c = 0; c < table.size(); ++c) {
        if (count[c] >= settings.min_samples && sum[c] > 0.0) {
          table[c] = sum[c] / static_cast<double>(count[c]) / 2.0;
        }
      }
    }
  }
}

// The mean of value / c over the samples, c from `scale` (the calibrated mean).
template <class Scale>
double calibrated_mean(const std::vector<Sample>& samples, Scale scale) {
  double sum = 0.0;
  for (const Sample& s : samples) sum += s.value / scale(s);
  return samples.empty() ? 0.0 : sum / static_cast<double>(samples.size());
}

}  // namespace

void CalibrationSettings::validate() const {
  // Each track is drawn and run in turn, its samples kept: a count is held to what a split may
  // hold (datasets::kMaxSplitTracks), not left to run for hours and out of memory.
  require(tracks >= 0 && tracks <= datasets::kMaxSplitTracks, "tracks",
          "must be in [0, 10⁶] (0: no calibration), got " + std::to_string(tracks));
  const int max = CovarianceCalibration::kMaxEntries;
  require(start_entries >= 1 && start_entries <= max, "start_entries",
          "must be in [1, " + std::to_string(max) + "], got " + std::to_string(start_entries));
  require(level_bins >= 1 && level_bins <= max, "level_bins",
          "must be in [1, " + std::to_string(max) + "], got " + std::to_string(level_bins));
  require(memory >= 0.0 && memory < 1.0, "memory", "must be in [0, 1)");
  require(nis_cap > 0.0 && std::isfinite(nis_cap), "nis_cap", "must be a finite number > 0");
  require(min_samples >= 1, "min_samples", "must be ≥ 1, got " + std::to_string(min_samples));
}

CalibrationFit fit_calibration(const std::filesystem::path& model_file,
                               const CalibrationSettings& settings) {
  settings.validate();
  const io::ModelFileReader reader(model_file);
  CalibrationFit fit;
  fit.calibration.memory = settings.memory;
  fit.calibration.nis_cap = settings.nis_cap;
  const io::Provenance& p = reader.provenance();
  if (p.regime_toml.empty() || settings.tracks < 1) return fit;
  const datasets::Regime regime = datasets::parse_regime(p.regime_toml, p.regime_name).regime;
  const int tracks =
      regime.recorded
          ? std::min(settings.tracks, datasets::split_size(regime, datasets::Split::kTraining))
          : settings.tracks;
  // The model's own filter, without any calibration the file may carry already.
  const FilterMaker raw = model_kind(p.model_kind, "model_kind").load(reader, kDefaultMaxGap);
  const bool polar = raw.options.measurement_kind == MeasurementKind::kPolar;
  const Eigen::Vector2d origin = polar ? regime.sensor.position : Eigen::Vector2d::Zero();
  const auto identity = std::make_shared<const CovarianceCalibration>();
  std::vector<Sample> nis, nees;
  for (int i = 0; i < tracks; ++i) {
    const datasets::Track track = datasets::draw_track(regime, datasets::Split::kTraining, i, 0);
    auto owned = std::make_unique<CalibratedFilter>(raw.make(), identity);
    const CalibratedFilter& filter = *owned;
    Tracker tracker(std::move(owned), raw.options);
    for (int k = 0; k < track.plots.rows(); ++k) {
      const bool started = tracker.initialized();
      const Sample before{filter.plots_used(), filter.nis_level(), 0.0};
      const TrackStepResult result = tracker.process(k, track.plots.row(k).transpose());
      if (!started || result.event != TrackEvent::kUpdated) continue;
      const Eigen::Vector2d truth = datasets::position_at(track, k);
      const StepConsistency c = step_consistency(
          filter, truth.allFinite() ? Eigen::Vector2d(truth - origin) : Eigen::Vector2d::Zero());
      if (std::isfinite(c.nis)) nis.push_back({before.used, before.level, c.nis});
      if (truth.allFinite() && std::isfinite(c.position_nees)) {
        nees.push_back({filter.plots_used(), filter.nis_level(), c.position_nees});
      }
    }
  }
  fit.tracks = tracks;
  fit.plots = static_cast<long>(nis.size());
  fit.truths = static_cast<long>(nees.size());
  if (fit.plots < static_cast<long>(settings.min_samples) * settings.level_bins) return fit;
  // The level's bins: quantiles of the levels the plots met.
  std::vector<double> levels;
  levels.reserve(nis.size());
  for (const Sample& s : nis) levels.push_back(s.level);
  std::sort(levels.begin(), levels.end());
  CovarianceCalibration& cal = fit.calibration;
  cal.edges.clear();
  for (int b = 1; b < settings.level_bins; ++b) {
    const double edge = levels[levels.size() * static_cast<std::size_t>(b) /
                               static_cast<std::size_t>(settings.level_bins)];
    if (cal.edges.empty() || edge > cal.edges.back()) cal.edges.push_back(edge);
  }
  fit_tables(nis, settings, cal, cal.start_innovation, cal.level_innovation);
  fit_tables(nees, settings, cal, cal.start_state, cal.level_state);
  cal.validate();
  fit.fitted = true;
  const auto one = [](const Sample&) { return 1.0; };
  fit.nis_before = calibrated_mean(nis, one);
  fit.nis_after =
      calibrated_mean(nis, [&](const Sample& s) { return cal.innovation_scale(s.used, s.level); });
  fit.nees_before = calibrated_mean(nees, one);
  fit.nees_after =
      calibrated_mean(nees, [&](const Sample& s) { return cal.state_scale(s.used, s.level); });
  return fit;
}

void store_calibration(const std::filesystem::path& model_file,
                       const CovarianceCalibration& calibration) {
  calibration.validate();
  const std::int64_t reader_version = io::ModelFileReader(model_file).schema_version();
  {
    auto in = std::make_unique<io::ContainerReader>(model_file, io::kModelFormat);
    io::ContainerWriter out(model_file, io::kModelFormat);
    for (const std::string& object : in->objects()) {
      if (object.starts_with("/calibration")) continue;  // rewritten below
      if (object != "/" && in->kind(object) == io::ObjectKind::kGroup) out.create_group(object);
      if (in->kind(object) == io::ObjectKind::kDataset) out.write(object, in->read(object));
      for (const std::string& name : in->attribute_names(object)) {
        out.set_attribute(object, name, *in->attribute(object, name));
      }
    }
    in.reset();
    // A file with a calibration is at least version 4 (calibrated_filter.hpp).
    out.set_attribute("/", "schema_version",
                      std::max<std::int64_t>(reader_version, kCalibrationSchemaVersion));
    out.create_group("/calibration");
    out.set_attribute("/calibration", "memory", calibration.memory);
    out.set_attribute("/calibration", "nis_cap", calibration.nis_cap);
    out.set_attribute("/calibration", "units", std::string("memory=1,nis_cap=1"));
    const auto table = [&](const std::string& name, const std::vector<double>& values) {
      const std::string dataset = "/calibration/" + name;
      out.write(dataset, io::Array::from_vector(Eigen::Map<const Eigen::VectorXd>(
                             values.data(), static_cast<Eigen::Index>(values.size()))));
      out.set_attribute(dataset, "units", std::string("1"));
    };
    table("start_innovation", calibration.start_innovation);
    table("start_state", calibration.start_state);
    if (!calibration.edges.empty()) table("edges", calibration.edges);
    table("level_innovation", calibration.level_innovation);
    table("level_state", calibration.level_state);
    out.commit();
  }
  (void)check_model_file(model_file);  // the rewritten file reads whole
}

std::string describe(const CalibrationFit& fit) {
  std::ostringstream text;
  if (!fit.fitted) {
    text << "no covariance calibration ("
         << (fit.tracks > 0 ? std::to_string(fit.plots) + " plots are too few to fit"
                            : std::string("no regime recorded to calibrate on"))
         << ")";
    return text.str();
  }
  text << "covariance calibration on " << fit.tracks << " training tracks: mean NIS "
       << fit.nis_before << " → " << fit.nis_after << " over " << fit.plots << " plots";
  if (fit.truths > 0) {
    text << ", mean position NEES " << fit.nees_before << " → " << fit.nees_after;
  } else {
    text << " (no truth: P is not calibrated)";
  }
  return text.str();
}

}  // namespace imm::trainer
