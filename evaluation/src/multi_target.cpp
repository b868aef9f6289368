// SPDX-License-Identifier: Apache-2.0
#include "imm/evaluation/multi_target.hpp"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>

#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/datasets/regime.hpp"
#include "imm/datasets/scene.hpp"
#include "imm/datasets/track.hpp"
#include "imm/evaluation/experiments.hpp"
#include "imm/evaluation/gospa.hpp"
#include "imm/evaluation/report.hpp"
#include "imm/trainer/provenance.hpp"

namespace imm::evaluation {
namespace {

// The scenes of the settings (datasets/scene.hpp): test tracks of the regime.
datasets::Scene draw_scene(const datasets::Regime& regime, const MultiTargetSettings& s, int run) {
  const datasets::SceneSpec spec{s.targets, s.detection_probability, s.clutter_per_scan};
  return datasets::draw_scene(regime, spec, datasets::Split::kTest, run, s.seed);
}

}  // namespace

void MultiTargetSettings::validate() const {
  if (targets < 1) throw InvalidParameter("targets", "must be ≥ 1");
  if (!(detection_probability > 0.0) || detection_probability > 1.0) {
    throw InvalidParameter("detection_probability", "must be in (0, 1]");
  }
  if (!(clutter_per_scan >= 0.0) || clutter_per_scan > 1000.0) {
    throw InvalidParameter("clutter_per_scan", "must be in [0, 1000]");
  }
  if (runs < 2) throw InvalidParameter("runs", "must be ≥ 2 (the interval needs scenes)");
  if (runs > datasets::kMaxSplitTracks) {
    throw InvalidParameter("runs", "at most 10⁶ scenes, got " + std::to_string(runs));
  }
  if (warm_up < 0) throw InvalidParameter("warm_up", "must be ≥ 0");
  if (!(cutoff >= 0.0) || !std::isfinite(cutoff)) throw InvalidParameter("cutoff", "must be ≥ 0");
}

namespace {

// InvalidParameter("models") for a model of another sample period, length unit or plot space
// than the regime's (plots_mismatch): it would step once a scan over the wrong interval, read the
// scenes' plots 1000 times off or take ranges for x — silently wrong figures. A range sensor's
// models take the sensor's own plots, whatever their measurement kind says.
void require_the_regimes_plots(const datasets::Regime& regime, const std::filesystem::path& path,
                               const FilterMaker& maker) {
  std::optional<datasets::SensorKind> sensor;
  if (regime.sensor.kind != datasets::SensorKind::kRangeSensor) {
    sensor = maker.options.measurement_kind == MeasurementKind::kPolar
                 ? datasets::SensorKind::kPolar
                 : datasets::SensorKind::kCartesian;
  }
  const std::string mismatch =
      plots_mismatch(maker.options.sample_period, maker.provenance.length_unit, sensor, regime);
  if (!mismatch.empty()) throw InvalidParameter("models", path.string() + ": " + mismatch);
}

}  // namespace

MultiTargetResult run_multi_target(const datasets::Regime& regime,
                                   const std::vector<std::filesystem::path>& models,
                                   MultiTargetSettings settings) {
  settings.validate();
  if (models.empty()) throw InvalidParameter("models", "name at least one model file");
  if (regime.recorded) throw InvalidParameter("regime", "a drawn regime: scenes need truth");
  if (settings.gnn.max_speed == 0.0) settings.gnn.max_speed = 1.5 * regime.max_speed();
  MultiTargetResult result;
  result.cutoff = settings.cutoff > 0.0 ? settings.cutoff : 10.0 * regime.position_sigma();
  for (const std::filesystem::path& path : models) {
    const FilterMaker maker = load_filter_maker(path);
    MultiTargetFigures figures;
    figures.model = path.string();
    figures.per_run = Eigen::VectorXd::Zero(settings.runs);
    if (!maker.make()->has_split_cycle()) {
      if (result.models.empty()) {
        throw InvalidParameter("models", path.string() +
                                             " (the reference) does not split its cycle: name "
                                             "another kind first");
      }
      figures.refused = "its filter does not split its cycle (" + maker.provenance.model_kind +
                        "): the GNN tracker gates on the prediction";
      result.models.push_back(std::move(figures));
      continue;
    }
    // A model listed as not run above is not run on plots it would read wrongly either.
    require_the_regimes_plots(regime, path, maker);
    double scored = 0.0;
    for (int run = 0; run < settings.runs; ++run) {
      // Drawn again for each model (a scene is a function of its index), not held: a thousand
      // scenes of 300 scans at the densest clutter hold 6 GB; drawing costs little beside
      // tracking.
      const datasets::Scene scene = draw_scene(regime, settings, run);
      // Where there is clutter, the tracker confirms by the likelihood ratio against its density
      // (uniform over the scene's plot-space box), which charges a wide prediction for its width.
      GnnSettings gnn = settings.gnn;
      if (settings.clutter_per_scan > 0.0 && gnn.clutter_density == 0.0) {
        gnn.clutter_density = settings.clutter_per_scan / (scene.high - scene.low).prod();
        gnn.detection_probability = settings.detection_probability;
      }
      GnnTracker tracker(maker, gnn);
      double run_sum = 0.0;
      int run_scans = 0;
      // Track continuity: each target's last track id, and the target each id last followed.
      std::vector<int> last_id(scene.targets.size(), -1);
      std::map<int, std::size_t> followed;
      for (std::size_t k = 0; k < scene.plots.size(); ++k) {
        tracker.process(static_cast<std::int64_t>(k), scene.plots[k]);
        if (static_cast<int>(k) < settings.warm_up) continue;
        Eigen::Matrix2Xd truth(2, static_cast<Eigen::Index>(scene.targets.size()));
        for (std::size_t j = 0; j < scene.targets.size(); ++j) {
          truth.col(static_cast<Eigen::Index>(j)) =
              datasets::position_at(scene.targets[j], static_cast<Eigen::Index>(k));
        }
        const std::vector<GnnEstimate> confirmed = tracker.estimates();
        Eigen::Matrix2Xd estimates(2, static_cast<Eigen::Index>(confirmed.size()));
        for (std::size_t e = 0; e < confirmed.size(); ++e) {
          estimates.col(static_cast<Eigen::Index>(e)) = confirmed[e].position;
        }
        const Gospa g = gospa(truth, estimates, result.cutoff);
        for (std::size_t j = 0; j < scene.targets.size(); ++j) {
          const int e = g.estimate_of[j];
          if (e < 0) continue;
          const int id = confirmed[static_cast<std::size_t>(e)].id;
          if (last_id[j] >= 0 && id != last_id[j]) {
            // Another track now follows target j: one that followed another target (a swap) or
            // a new one (a break).
            const auto before = followed.find(id);
            (before != followed.end() && before->second != j ? figures.swaps : figures.breaks) +=
                1.0;
          }
          last_id[j] = id;
          followed[id] = j;
        }
        run_sum += g.distance;
        ++run_scans;
        figures.localization += g.localization;
        figures.missed += g.missed;
        figures.false_tracks += g.false_tracks;
      }
      figures.per_run(run) = run_sum / std::max(run_scans, 1);
      figures.tracks_started += tracker.tracks_started();
      scored += run_scans;
    }
    figures.gospa = figures.per_run.mean();
    figures.localization /= std::max(scored, 1.0);
    figures.missed /= std::max(scored, 1.0);
    figures.false_tracks /= std::max(scored, 1.0);
    figures.tracks_started /= settings.runs;
    figures.breaks /= settings.runs;
    figures.swaps /= settings.runs;
    result.models.push_back(std::move(figures));
  }
  for (MultiTargetFigures& f : result.models) {
    if (!f.refused.empty()) continue;
    f.versus_first = paired_difference(settings.runs, mean_of(f.per_run),
                                       mean_of(result.models.front().per_run), settings.seed);
  }
  return result;
}

namespace {

// One condition's table on stdout and its entry of metrics.json.
nlohmann::json report_condition(const datasets::Regime& regime, const MultiTargetSettings& s,
                                const MultiTargetResult& result) {
  const std::string_view unit = datasets::to_string(regime.units);
  std::cout
      << "Multi-target scenes of " << regime.name << ": " << s.runs << " scenes of " << s.targets
      << " targets, Pd " << s.detection_probability << ", " << s.clutter_per_scan
      << " false plots per scan; GOSPA (p = 2, c = " << result.cutoff << ' ' << unit
      << ") per scan from scan " << s.warm_up
      << ", GNN tracker. At each scan GOSPA² is the sum of its localization, missed and false "
         "parts ("
      << unit << "²); the table gives each one's mean over the scans\n\n";
  std::vector<std::vector<std::string>> rows;
  nlohmann::json models = nlohmann::json::array();
  for (const MultiTargetFigures& f : result.models) {
    if (!f.refused.empty()) {
      rows.push_back({f.model, "—", "—", "—", "—", "—", "—", "—", "not run: " + f.refused});
      models.push_back({{"model", f.model}, {"refused", f.refused}});
      continue;
    }
    rows.push_back({f.model, cell(f.gospa, 2), cell(f.localization, 2), cell(f.missed, 2),
                    cell(f.false_tracks, 2), cell(f.tracks_started, 2), cell(f.breaks, 2),
                    cell(f.swaps, 2), &f == &result.models.front() ? "—" : f.versus_first.text(2)});
    models.push_back({{"model", f.model},
                      {"gospa", f.gospa},
                      {"localization", f.localization},
                      {"missed", f.missed},
                      {"false", f.false_tracks},
                      {"tracks_started_per_scene", f.tracks_started},
                      {"breaks_per_scene", f.breaks},
                      {"swaps_per_scene", f.swaps},
                      {"gospa_minus_first",
                       {f.versus_first.estimate, f.versus_first.lower, f.versus_first.upper}}});
  }
  std::cout << markdown_table(
                   {"model", "GOSPA", "localization", "missed", "false", "tracks started per scene",
                    "breaks per scene", "swaps per scene", "GOSPA − first [95 %]"},
                   rows)
            << '\n'
            << kDifferenceConvention << "\n\n";
  return {{"detection_probability", s.detection_probability},
          {"clutter_per_scan", s.clutter_per_scan},
          {"models", models}};
}

}  // namespace

MultiTargetConditions evaluate_multi_target(const MultiTargetOptions& options) {
  if (options.models.empty()) throw InvalidParameter("models", "at least one model file is needed");
  const std::filesystem::path regime_path = options.regime.value_or(options.models.front());
  const datasets::RegimeFile regime = load_regime_option(regime_path);
  const datasets::SceneSpec& scene = regime.regime.scene;
  const std::vector<double> pds = options.detection_probabilities.empty()
                                      ? std::vector<double>{scene.detection_probability}
                                      : options.detection_probabilities;
  const std::vector<double> clutters = options.clutter_densities.empty()
                                           ? std::vector<double>{scene.clutter_per_scan}
                                           : options.clutter_densities;
  MultiTargetConditions out;
  out.regime = regime.regime;
  std::vector<MultiTargetSettings> grid;  // checked before any scene is run
  for (const double pd : pds) {
    for (const double clutter : clutters) {
      MultiTargetSettings s = options.settings;
      s.targets = options.targets.value_or(scene.targets);
      s.detection_probability = pd;
      s.clutter_per_scan = clutter;
      s.validate();
      grid.push_back(s);
    }
  }
  for (const MultiTargetSettings& s : grid) {
    out.conditions.push_back({s, run_multi_target(regime.regime, options.models, s)});
  }
  return out;
}

int report_multi_target(const MultiTargetConditions& result, const MultiTargetOptions& options) {
  nlohmann::json conditions = nlohmann::json::array();
  double cutoff = 0.0;
  for (const auto& [settings, figures] : result.conditions) {
    cutoff = figures.cutoff;
    conditions.push_back(report_condition(result.regime, settings, figures));
  }
  const MultiTargetSettings& s = result.conditions.front().settings;
  std::filesystem::create_directories(options.out);
  trainer::write_json_atomically(options.out / "metrics.json", {{"experiment", "multi-target"},
                                                                {"regime", result.regime.name},
                                                                {"runs", s.runs},
                                                                {"targets", s.targets},
                                                                {"seed", s.seed},
                                                                {"cutoff", cutoff},
                                                                {"conditions", conditions}});
  return 0;
}

int run_multi_target_experiment(const MultiTargetOptions& options) {
  return report_multi_target(evaluate_multi_target(options), options);
}

}  // namespace imm::evaluation
