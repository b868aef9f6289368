// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/experiment.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <utility>

#include "imm/evaluation/experiments.hpp"

namespace imm::evaluation {
namespace {

std::string number(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

std::string sensor_name(datasets::SensorKind kind) {
  return std::string(datasets::to_string(kind));
}

bool close(double a, double b) { return std::abs(a - b) <= 1e-9 * std::max(std::abs(a), 1.0); }

}  // namespace

std::filesystem::path CommonOptions::model_path() const {
  std::filesystem::path named(model);
  if (named.has_parent_path() && std::filesystem::exists(named)) return named;
  if (named.extension() == ".h5") return models / named;
  return models / (model + ".h5");
}

void ExperimentResult::start(std::string name, const CommonOptions& common) {
  experiment = std::move(name);
  model = common.model_path();
  seed = common.seed;
}

void ExperimentResult::start(std::string name, const CommonOptions& common,
                             const io::Provenance& recorded) {
  start(std::move(name), common);
  regimes = evaluation_regimes(common, recorded, model);
}

const FilterOutcome& ExperimentResult::filter(const std::string& name) const {
  for (const FilterOutcome& f : filters) {
    if (f.name == name) return f;
  }
  throw std::out_of_range(experiment + ": no filter named '" + name + "'");
}

int ExperimentResult::exit_code() const {
  if (!failures.empty()) return support::exit_code::kEvaluationGateFailed;
  return findings.empty() ? 0 : support::exit_code::kFindings;
}

std::string EvaluationRegimes::describe() const {
  std::string text = "regime " + evaluated.regime.name;
  if (!evaluated.regime.file.empty()) text += " (" + evaluated.regime.file + ")";
  if (off_training()) {
    text += "; the model was trained for regime " + trained.regime.name +
            ": evaluated off its training maneuvers";
  } else {
    text += ", the model's own";
  }
  return text;
}

namespace {

datasets::RegimeFile recorded_regime(const io::Provenance& model,
                                     const std::filesystem::path& path) {
  if (model.regime_toml.empty()) {
    throw std::runtime_error(path.string() +
                             ": the model records no regime (written before regimes); retrain it");
  }
  return datasets::parse_regime(model.regime_toml,
                                path.string() + ": /@regime_toml (" + model.regime_name + ")");
}

}  // namespace

datasets::RegimeFile load_regime_option(const std::filesystem::path& path) {
  if (path.extension() == ".h5") {
    const io::ModelFileReader reader(path);
    return recorded_regime(reader.provenance(), path);
  }
  return datasets::load_regime(path);
}

EvaluationRegimes evaluation_regimes(const CommonOptions& options, const io::Provenance& model,
                                     const std::filesystem::path& path) {
  EvaluationRegimes regimes;
  regimes.trained = recorded_regime(model, path);
  regimes.evaluated = options.regime ? load_regime_option(*options.regime) : regimes.trained;
  return regimes;
}

EvaluationRegimes evaluation_regimes(const datasets::RegimeFile& evaluated,
                                     const io::Provenance& model,
                                     const std::filesystem::path& path) {
  return {evaluated, recorded_regime(model, path)};
}

std::string plots_mismatch(double sample_period, std::string_view length_unit,
                           std::optional<datasets::SensorKind> sensor,
                           const datasets::Regime& regime) {
  if (!close(sample_period, regime.sample_period)) {
    return "sample_period: the model is built for T = " + number(sample_period) +
           " s, the regime's plots come every " + number(regime.sample_period) + " s";
  }
  const std::string_view units = datasets::to_string(regime.units);
  if (!length_unit.empty() && length_unit != units) {
    return "units: the model works in " + std::string(length_unit) + ", the regime in " +
           std::string(units);
  }
  if (sensor && *sensor != regime.sensor.kind) {
    return "sensor.kind: the model needs a " + sensor_name(*sensor) + " sensor, the regime has a " +
           sensor_name(regime.sensor.kind) + " one";
  }
  return "";
}

void check_model(const ModelRequirements& model, const EvaluationRegimes& regimes,
                 const std::filesystem::path& path) {
  const datasets::Regime& r = regimes.evaluated.regime;
  const datasets::Regime& own = regimes.trained.regime;
  // Both files named: the model's, and the regime's (a file, or the regime the model records).
  const std::string where = "model " + path.string() + " on regime " + r.name + " (" +
                            (r.file.empty() ? "recorded in the model" : r.file) + "): ";
  const std::string mismatch =
      plots_mismatch(model.sample_period, datasets::to_string(own.units), model.sensor, r);
  if (!mismatch.empty()) throw std::runtime_error(where + mismatch);
  if (r.sensor.kind == datasets::SensorKind::kRangeSensor &&
      own.sensor.samples_digest != r.sensor.samples_digest) {
    throw std::runtime_error(where +
                             "sensor.samples: the model was fitted to another sensor's "
                             "samples");
  }
  if (r.sensor.kind == datasets::SensorKind::kRangeSensor && !own.sensor.sampled &&
      !(own.sensor.distortion.knee == r.sensor.distortion.knee &&
        own.sensor.distortion.softness == r.sensor.distortion.softness)) {
    throw std::runtime_error(where + "sensor.knee/softness: the model was fitted to another " +
                             "distortion (knee " + number(own.sensor.distortion.knee) +
                             " m, softness " + number(own.sensor.distortion.softness) + " m)");
  }
  // A σ a recorded regime estimated from its plots — the evaluated one's, or the one the model
  // was trained with — is an estimate: within 10 % it is the same sensor (the estimate's own
  // spread on a few dozen tracks is a few percent).
  const bool estimated = r.sensor.estimate_sigma || own.sensor.estimate_sigma;
  const auto same_sigma = [&](double regime_sigma, double model_sigma) {
    return estimated ? std::abs(regime_sigma - model_sigma) <= 0.1 * model_sigma
                     : close(regime_sigma, model_sigma);
  };
  for (int c = 0; c < r.case_count(); ++c) {
    const datasets::SensorNoise& noise = r.noise_of(c);
    if (model.plot_sigma &&
        !(same_sigma(noise.sigma(0), *model.plot_sigma) &&
          (model.azimuth_sigma || same_sigma(noise.sigma(1), *model.plot_sigma)) &&
          noise.correlation == 0.0)) {
      throw std::runtime_error(
          where + "sensor.sigma: the model is built for " +
          (model.azimuth_sigma ? "σ_r = " + number(*model.plot_sigma)
                               : "σ = " + number(*model.plot_sigma) + " per axis, uncorrelated") +
          "; the regime" + (r.scripted() ? "'s case '" + r.case_name(c) + "'" : "") + " has [" +
          number(noise.sigma(0)) + ", " + number(noise.sigma(1)) + "]");
    }
    if (model.azimuth_sigma && !same_sigma(noise.sigma(1), *model.azimuth_sigma)) {
      throw std::runtime_error(where + "sensor.azimuth_sigma_deg: the model is built for another " +
                               "azimuth σ");
    }
  }
}

datasets::TrackSet test_tracks(const datasets::Regime& regime, const CommonOptions& options) {
  datasets::TrackSet data = datasets::draw_split(regime, datasets::Split::kTest, options.seed,
                                                 options.runs ? *options.runs : -1);
  if (!data.recording_truth.empty()) {  // partial truth: the tracks with it, or all by the plots
    std::size_t with = 0;
    for (std::size_t i = 0; i < data.tracks.size(); ++i) with += data.track_has_truth(i) ? 1 : 0;
    if (!options.truth_tracks) {
      std::cout << "  " << with << " of " << data.tracks.size()
                << " test tracks have truth: every track is judged by the plots here; "
                   "--truth-tracks judges those "
                << with << " by their errors\n";
    } else {
      std::cout << "  --truth-tracks: the " << with << " of " << data.tracks.size()
                << " test tracks with truth\n";
      std::vector<datasets::Track> tracks;
      std::vector<int> recording;
      for (std::size_t i = 0; i < data.tracks.size(); ++i) {
        if (!data.track_has_truth(i)) continue;
        tracks.push_back(std::move(data.tracks[i]));
        recording.push_back(data.recording[i]);
      }
      data.tracks = std::move(tracks);
      data.recording = std::move(recording);
      data.recording_truth.clear();
      data.has_truth = true;
    }
  } else if (options.truth_tracks && !data.has_truth) {
    throw std::runtime_error(regime.file + ": --truth-tracks: no test track of regime '" +
                             regime.name + "' has truth");
  }
  return data;
}

std::string case_label(const datasets::Regime& regime, int case_index) {
  return regime.scripted() ? regime.case_name(case_index) : "all tracks";
}

std::vector<CaseTracks> tracks_by_case(const datasets::Regime& regime,
                                       const datasets::TrackSet& data) {
  std::vector<CaseTracks> cases(static_cast<std::size_t>(regime.case_count()));
  for (std::size_t c = 0; c < cases.size(); ++c) {
    cases[c].index = static_cast<int>(c);
    cases[c].name = case_label(regime, static_cast<int>(c));
    cases[c].tracks.regime = data.regime;
    cases[c].tracks.split = data.split;
    cases[c].tracks.seed = data.seed;
    cases[c].tracks.sample_period = data.sample_period;
    cases[c].tracks.scans = data.scans;
  }
  for (const datasets::Track& track : data.tracks) {
    cases[static_cast<std::size_t>(track.case_index)].tracks.tracks.push_back(track);
  }
  std::erase_if(cases, [](const CaseTracks& c) { return c.tracks.tracks.empty(); });
  return cases;
}

bool learned_part_off(const io::Provenance& provenance) {
  const auto on = provenance.training_metrics.find("learned_part_on");
  return on != provenance.training_metrics.end() && on->second == 0.0;
}

bool paper_scenario(const datasets::Regime& regime) {
  static constexpr std::array<std::string_view, 11> kPresets = {"ga_imm_training",
                                                                "ga_imm_table3",
                                                                "input_estimator_training",
                                                                "input_estimator_tables",
                                                                "wimm_training",
                                                                "wimm_table2",
                                                                "fcm_imm_training",
                                                                "fcm_imm_zigzag",
                                                                "fcm_imm_zigzag_literal",
                                                                "fimm_table1",
                                                                "fimm_table1_hard"};
  return std::find(kPresets.begin(), kPresets.end(), regime.name) != kPresets.end();
}

void print_findings(const std::vector<std::string>& findings) {
  std::cout << "Findings (the learned model against the baselines tuned on its regime; not "
               "failures): "
            << (findings.empty() ? "none" : std::to_string(findings.size())) << '\n';
  for (const auto& finding : findings) std::cout << "  - " << finding << '\n';
}

int finish_report(const std::filesystem::path& out, bool plotted,
                  const std::vector<std::string>& failures, bool failures_printed,
                  const std::vector<std::string>& findings) {
  std::cout << "\nwrote metrics.json, details.json, CSV series"
            << (plotted ? " and PNG plots" : " (plots skipped: gnuplot unavailable or failed)")
            << " in " << out.string() << '\n';
  if (!failures_printed) {
    for (const auto& failure : failures) std::cerr << "imm-eval: gate failed: " << failure << '\n';
  }
  if (!failures.empty()) return support::exit_code::kEvaluationGateFailed;
  return findings.empty() ? 0 : support::exit_code::kFindings;
}

}  // namespace imm::evaluation
