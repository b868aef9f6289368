// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/model_files/envelope.hpp"

#include <algorithm>
#include <memory>
#include <sstream>
#include <vector>

#include "imm/datasets/regime_file.hpp"
#include "imm/datasets/track.hpp"
#include "imm/io/container_file.hpp"
#include "imm/io/model_file.hpp"
#include "imm/load.hpp"
#include "imm/trainer/model_files/seal.hpp"

namespace imm::trainer {

EnvelopeCalibration calibrate_envelope(const std::filesystem::path& model_file, int tracks) {
  const io::ModelFileReader reader(model_file);
  EnvelopeCalibration c;
  c.settings = reader.envelope();
  c.settings.scale = 1.0;
  c.settings.dof = 0.0;
  const io::Provenance& p = reader.provenance();
  if (p.regime_toml.empty() || tracks < 1) return c;
  const datasets::Regime regime = datasets::parse_regime(p.regime_toml, p.regime_name).regime;
  const int window = c.settings.window;
  // A recorded regime has the validation windows it has; a drawn one draws fresh tracks.
  if (regime.recorded) {
    tracks = std::min(tracks, datasets::split_size(regime, datasets::Split::kValidation));
    c.recorded = true;
  }
  // The plots the model is built for: those whose noise is its R. A regime with one case per
  // plot noise (seed 002's Table 1) holds others, which the envelope must flag, not learn.
  const FilterMaker maker = load_filter_maker(reader);  // read once for every track
  const Eigen::Matrix2d R = maker.options.measurement_covariance;
  const auto built_for = [&](const datasets::Track& track) {
    return (track.noise.covariance() - R).cwiseAbs().maxCoeff() <= 1e-9 * R.cwiseAbs().maxCoeff();
  };
  const int cases = std::max<int>(1, static_cast<int>(regime.cases.size()));
  const int draws = regime.recorded ? tracks : tracks * cases;
  std::vector<datasets::Track> chosen;
  int examined = 0;
  for (; examined < draws && static_cast<int>(chosen.size()) < tracks; ++examined) {
    datasets::Track track = datasets::draw_track(regime, datasets::Split::kValidation, examined, 0);
    if (built_for(track)) chosen.push_back(std::move(track));
  }
  c.noise_mismatch = chosen.empty();
  c.other_noise = examined - static_cast<int>(chosen.size());
  if (c.noise_mismatch) {
    c.other_noise = 0;
    for (int i = 0; i < std::min(tracks, draws); ++i) {
      chosen.push_back(datasets::draw_track(regime, datasets::Split::kValidation, i, 0));
    }
  }
  std::vector<double> sums;
  for (const datasets::Track& track : chosen) {
    Tracker tracker(maker.make(), maker.options);
    for (int k = 0; k < track.plots.rows(); ++k) {
      (void)tracker.process(k, track.plots.row(k).transpose());
      // Disjoint full windows after the start has settled (two windows).
      if (k >= 2 * window && (k - 2 * window) % window == window - 1 &&
          tracker.envelope().filled() == window) {
        sums.push_back(tracker.envelope().mean() * window);
      }
    }
  }
  c.tracks = static_cast<int>(chosen.size());
  c.windows = static_cast<int>(sums.size());
  if (c.windows < 30) return c;  // too few to fit: the χ² defaults stay
  for (const double s : sums) c.mean += s;
  c.mean /= c.windows;
  for (const double s : sums) c.variance += (s - c.mean) * (s - c.mean);
  c.variance /= c.windows - 1;
  if (!(c.variance > 0.0) || !(c.mean > 0.0)) return c;
  c.settings.scale = c.variance / (2.0 * c.mean);
  c.settings.dof = 2.0 * c.mean * c.mean / c.variance;
  c.settings.validate();
  c.calibrated = true;
  return c;
}

void store_envelope(const std::filesystem::path& model_file, const EnvelopeSettings& settings) {
  settings.validate();
  {
    auto in = std::make_unique<io::ContainerReader>(model_file, io::kModelFormat);
    io::ContainerWriter out(model_file, io::kModelFormat);
    for (const std::string& object : in->objects()) {
      if (object != "/" && in->kind(object) == io::ObjectKind::kGroup) out.create_group(object);
      if (in->kind(object) == io::ObjectKind::kDataset) out.write(object, in->read(object));
      for (const std::string& name : in->attribute_names(object)) {
        if (object == "/envelope") continue;  // rewritten below
        out.set_attribute(object, name, *in->attribute(object, name));
      }
    }
    in.reset();
    out.create_group("/envelope");
    out.set_attribute("/envelope", "window", std::int64_t{settings.window});
    out.set_attribute("/envelope", "significance", settings.significance);
    out.set_attribute("/envelope", "scale", settings.scale);
    out.set_attribute("/envelope", "dof", settings.dof);
    out.set_attribute("/envelope", "units", std::string("significance=1,scale=1,dof=1"));
    out.commit();
  }
  (void)check_model_file(model_file);  // the rewritten file reads whole
}

EnvelopeCalibration calibrate_and_store_envelope(const std::filesystem::path& model_file,
                                                 int tracks) {
  EnvelopeCalibration c = calibrate_envelope(model_file, tracks);
  if (c.calibrated) store_envelope(model_file, c.settings);
  return c;
}

std::string describe(const EnvelopeCalibration& c) {
  std::ostringstream text;
  text << "envelope of " << c.settings.window << "-plot windows at " << c.settings.significance;
  if (!c.calibrated) {
    text << ": the χ² bounds of a consistent filter ("
         << (c.tracks > 0 ? std::to_string(c.windows) + " windows are too few to fit"
                          : std::string("no regime recorded to calibrate on"))
         << ")";
    return text.str();
  }
  text << ": NIS sums fitted as " << c.settings.scale << " · χ²(" << c.settings.dof << ") on "
       << c.windows << " windows of " << c.tracks
       << (c.recorded ? " validation recordings" : " fresh tracks") << " of the regime (mean "
       << c.mean << ", a consistent filter's " << 2 * c.settings.window << ")";
  if (c.other_noise > 0) {
    text << "; " << c.other_noise << " tracks of other plot noise than the model's R left out";
  }
  if (c.noise_mismatch) text << "; no track of the regime has the model's R: all were run";
  return text.str();
}

}  // namespace imm::trainer
