// SPDX-License-Identifier: Apache-2.0
// Every experiment's typed result as a dict: what it shares (ExperimentResult) under the same keys
// for every experiment, and its own tables under theirs. Differences are [estimate, lower, upper]
// (the 95 % paired-bootstrap interval), as in metrics.json. And a data set's tracks as arrays.
#include "lab_results.hpp"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/evaluation/experiments.hpp"

namespace py = pybind11;
namespace fs = std::filesystem;
namespace ev = imm::evaluation;

namespace {

py::list interval(const ev::Difference& d) {
  py::list values;
  values.append(d.estimate);
  values.append(d.lower);
  values.append(d.upper);
  return values;
}

py::dict zeta(const ev::ZetaDifference& d) {
  py::dict out;
  out["zeta_p"] = interval(d.zeta_p);
  out["zeta_v"] = interval(d.zeta_v);
  return out;
}

py::dict zeta_map(const std::map<std::string, ev::ZetaDifference>& differences) {
  py::dict out;
  for (const auto& [name, d] : differences) out[py::str(name)] = zeta(d);
  return out;
}

py::dict consistency(const ev::ConsistencySummary& c) {
  py::dict out;
  out["average"] = c.average;
  out["inside"] = c.inside;
  out["verdict"] = c.verdict();
  return out;
}

py::dict outcome(const ev::FilterOutcome& f) {
  py::dict out;
  out["modes"] = f.modes;
  out["zeta_p"] = f.zeta_p;
  out["zeta_v"] = f.zeta_v;
  out["position_rmse"] = f.position_rmse;
  out["velocity_rmse"] = f.velocity_rmse;
  out["position_nees"] = f.position_consistency.average;
  out["position_nees_scans_inside"] = f.position_consistency.inside;
  out["nis"] = f.nis_consistency.average;
  out["nis_scans_inside"] = f.nis_consistency.inside;
  out["rejected_steps"] = f.rejected_steps;
  out["position_error"] = f.position_error;  // P_e(k) per scan
  out["velocity_error"] = f.velocity_error;
  out["mean_mode_probabilities"] = f.mean_mode_probabilities;
  out["mode_names"] = f.mode_names;
  return out;
}

// The filters' figures as one table, a row per filter: a pandas.DataFrame where pandas is
// installed, else a dict of columns with the names under "filter".
py::object table(const std::vector<ev::FilterOutcome>& filters) {
  std::vector<std::string> names;
  std::vector<double> zeta_p, zeta_v, position_rmse, velocity_rmse, nees, nis, nees_in, nis_in;
  for (const ev::FilterOutcome& f : filters) {
    names.push_back(f.name);
    zeta_p.push_back(f.zeta_p);
    zeta_v.push_back(f.zeta_v);
    position_rmse.push_back(f.position_rmse);
    velocity_rmse.push_back(f.velocity_rmse);
    nees.push_back(f.position_consistency.average);
    nis.push_back(f.nis_consistency.average);
    nees_in.push_back(f.position_consistency.inside);
    nis_in.push_back(f.nis_consistency.inside);
  }
  py::dict columns;
  columns["zeta_p"] = zeta_p;
  columns["zeta_v"] = zeta_v;
  columns["position_rmse"] = position_rmse;
  columns["velocity_rmse"] = velocity_rmse;
  columns["position_nees"] = nees;
  columns["nis"] = nis;
  columns["position_nees_scans_inside"] = nees_in;
  columns["nis_scans_inside"] = nis_in;
  try {
    return py::module_::import("pandas").attr("DataFrame")(columns, py::arg("index") = names);
  } catch (py::error_already_set& error) {
    if (!error.matches(PyExc_ImportError)) throw;
  }
  columns["filter"] = names;
  return columns;
}

// What every experiment's result holds.
py::dict common(const ev::ExperimentResult& r) {
  py::dict out;
  out["experiment"] = r.experiment;
  out["model"] = r.model;
  out["regime"] =
      r.regimes.evaluated.regime.name.empty() ? r.tracks.regime : r.regimes.evaluated.regime.name;
  out["model_regime"] = r.regimes.trained.regime.name;
  out["seed"] = r.seed;
  out["runs"] = r.runs();
  out["scans"] = r.tracks.scans;
  out["dataset_digest"] = r.tracks.digest();
  out["has_truth"] = r.tracks.has_truth;
  py::dict filters;
  for (const ev::FilterOutcome& f : r.filters) filters[py::str(f.name)] = outcome(f);
  out["filters"] = filters;
  out["table"] = table(r.filters);
  out["failures"] = r.failures;
  out["findings"] = r.findings;
  out["exit_code"] = r.exit_code();
  return out;
}

py::object bar(const std::optional<ev::BarComparison>& c) {
  if (!c) return py::none();
  py::dict out;
  out["parameters"] = c->parameters;
  out["criteria"] = std::vector<std::string>(c->criteria.begin(), c->criteria.end());
  out["differences"] = py::make_tuple(interval(c->differences[0]), interval(c->differences[1]));
  out["verdict"] = c->verdict;
  out["summary"] = c->summary;
  py::dict filters;
  for (const ev::FilterOutcome& f : c->outcomes) filters[py::str(f.name)] = outcome(f);
  out["filters"] = filters;
  return out;
}

}  // namespace

py::dict to_dict(const ev::PlainImmResult& r) {
  py::dict out = common(r);
  out["source"] = r.source;
  out["imm_minus"] = zeta_map(r.imm_minus);
  out["versus_classical_bar"] = bar(r.versus_bar);
  return out;
}

py::dict to_dict(const ev::GaImmResult& r) {
  py::dict out = common(r);
  out["ga_imm_minus"] = zeta_map(r.ga_imm_minus);
  out["tuned"] = r.tuned;
  out["training_scores"] = r.training_scores;
  out["against_imm_tuned"] = r.against_imm_tuned;
  out["against_bar"] = r.against_bar;
  out["learned_part_on"] = r.learned_part_on;
  py::list spreads;
  for (const ev::ProcessNoiseSpread& s : r.spreads) {
    py::dict row;
    row["filter"] = s.filter;
    row["mode"] = s.mode;
    row["p01"] = s.p01;
    row["p50"] = s.p50;
    row["p99"] = s.p99;
    spreads.append(row);
  }
  out["process_noise_spread"] = spreads;
  return out;
}

py::dict to_dict(const ev::WimmResult& r) {
  py::dict out = common(r);
  out["parameters"] = r.parameters;
  py::list cases;
  for (const ev::WimmCase& c : r.cases) {
    py::dict one;
    one["name"] = c.name;
    one["runs"] = c.runs;
    py::dict filters;
    for (std::size_t k = 0; k < c.filters.size(); ++k) {
      const auto& s = c.scores[k];
      py::dict f;
      f["az_rmse"] = s.azimuth;
      f["az_rmse_settled"] = s.azimuth_settled;
      f["pos_rmse"] = s.position;
      f["pos_rmse_settled"] = s.position_settled;
      f["nees"] = s.nees_settled;
      if (k != 0) f["az_settled_minus_nimm"] = interval(c.versus_nimm[k]);
      f["position_nees"] = consistency(c.consistency[k].position_nees);
      f["nis"] = consistency(c.consistency[k].nis);
      filters[py::str(c.filters[k])] = f;
    }
    one["filters"] = filters;
    cases.append(one);
  }
  out["cases"] = cases;
  out["versus_classical_bar"] = bar(r.versus_bar);
  return out;
}

py::dict to_dict(const ev::FcmImmResult& r) {
  py::dict out = common(r);
  out["parameters"] = r.parameters;
  out["training_objective"] = r.training_objective;
  py::dict outcomes;
  for (const ev::FcmImmOutcome& o : r.outcomes) {
    py::dict f;
    for (int i = 0; i < 4; ++i) f[ev::kFcmImmFigures[i]] = o.figures[i];
    f["maneuver_fraction_straight"] = o.fraction_straight;
    f["maneuver_fraction_maneuver"] = o.fraction_maneuver;
    f["position_nees"] = consistency(o.position_nees);
    f["nis"] = consistency(o.nis);
    f["failed_steps"] = o.failed_steps;
    outcomes[py::str(o.name)] = f;
  }
  out["outcomes"] = outcomes;
  py::dict minus;
  for (const auto& [name, d] : r.fcm_imm_minus) {
    py::dict f;
    for (std::size_t i = 0; i < 4; ++i) f[ev::kFcmImmFigures[i]] = interval(d[i]);
    minus[py::str(name)] = f;
  }
  out["fcm_imm_minus"] = minus;
  out["learned_part_on"] = r.learned_part_on;
  out["versus_classical_bar"] = bar(r.versus_bar);
  return out;
}

py::dict to_dict(const ev::FimmResult& r) {
  py::dict out = common(r);
  out["settings"] = r.settings;
  py::list cases;
  for (const ev::FimmCase& c : r.cases) {
    py::dict one;
    one["name"] = c.name;
    one["runs"] = c.runs;
    one["R"] = c.measurement_variance;
    one["imm_mse"] = c.imm.mse;
    one["fimm_mse"] = c.fimm.mse;
    one["fimm_iekf_mse"] = c.iekf.mse;
    one["fimm_minus_imm"] = interval(c.fimm_minus_imm);
    one["iekf_minus_imm"] = interval(c.iekf_minus_imm);
    one["fimm_clamped_share"] = c.fimm.clamped;
    one["nees"] = py::make_tuple(c.imm.nees, c.fimm.nees, c.iekf.nees);
    cases.append(one);
  }
  out["cases"] = cases;
  out["sensor_curve"] = r.sensor_curve;
  return out;
}

py::dict to_dict(const ev::InputEstimatorResult& r) {
  py::dict out = common(r);
  py::list cases;
  for (const ev::InputEstimatorVerdicts& v : r.verdicts) {
    py::dict one;
    one["name"] = v.name;
    py::dict minus_cv, minus_imm;
    for (std::size_t q = 0; q < 3; ++q) {
      minus_cv[py::str(std::string(ev::kInputEstimatorQuantities[q]) + "_mse")] =
          interval(v.corrected_minus_cv[q]);
    }
    for (std::size_t q = 0; q < 2; ++q) {
      minus_imm[py::str(std::string(ev::kInputEstimatorQuantities[q + 1]) + "_mse")] =
          interval(v.corrected_minus_imm_tuned[q]);
    }
    one["corrected_minus_cv"] = minus_cv;
    one["corrected_minus_imm_tuned"] = minus_imm;
    one["versus_imm_tuned"] = v.versus_imm_tuned;
    cases.append(one);
  }
  for (std::size_t c = 0, v = 0; c < r.cases.size(); ++c) {
    const ev::InputEstimatorCase& one = r.cases[c];
    if (one.cv.rows() == 0) continue;
    py::dict mse;
    for (int q = 0; q < 3; ++q) {
      py::dict row;
      row["cv_kf"] = one.cv.col(q).mean();
      row["corrected_kf"] = one.corrected.col(q).mean();
      row["true_input_kf"] = one.floor.col(q).mean();
      if (q > 0) row["imm_tuned"] = one.imm.col(q).mean();
      mse[py::str(std::string(ev::kInputEstimatorQuantities[q]) + "_mse")] = row;
    }
    cases[v++].cast<py::dict>()["mse"] = mse;
  }
  out["cases"] = cases;
  out["wins"] = r.wins;
  out["cells"] = r.cells;
  out["versus_classical_bar"] = bar(r.versus_bar);
  return out;
}

py::dict to_dict(const ev::RankResult& r) {
  py::dict out = common(r);
  out["regime"] = r.regime.name;
  out["tracker"] = r.ranked[r.choice.winner].name;
  out["tracker_file"] = r.files[r.choice.winner];
  out["bar"] = r.ranked[r.bar].name;
  out["reason"] = r.choice.reason;
  py::list ranking;
  for (std::size_t place = 0; place < r.choice.order.size(); ++place) {
    const std::size_t i = r.choice.order[place];
    const ev::RankedFilter& f = r.ranked[i];
    py::dict row;
    row["place"] = place + 1;
    row["filter"] = f.name;
    row["file"] = r.files[i];
    row["kind"] = f.kind;
    row["classical"] = i < r.classical;
    row["eligible"] = r.eligible(i);
    row["zeta_p"] = f.zeta_p;
    row["zeta_v"] = f.zeta_v;
    row["verdict"] = ev::verdict_against_baseline(f);
    if (!f.baseline) {
      row["versus_bar"] =
          py::make_tuple(interval(f.versus_baseline_p), interval(f.versus_baseline_v));
    }
    ranking.append(row);
  }
  out["ranking"] = ranking;
  return out;
}

py::list to_list(const ev::MultiTargetConditions& r) {
  py::list conditions;
  for (const auto& [settings, figures] : r.conditions) {
    py::dict condition;
    condition["regime"] = r.regime.name;
    condition["targets"] = settings.targets;
    condition["detection_probability"] = settings.detection_probability;
    condition["clutter_per_scan"] = settings.clutter_per_scan;
    condition["runs"] = settings.runs;
    condition["seed"] = settings.seed;
    condition["cutoff"] = figures.cutoff;
    py::list models;
    for (const ev::MultiTargetFigures& f : figures.models) {
      py::dict m;
      m["model"] = f.model;
      if (!f.refused.empty()) {
        m["refused"] = f.refused;
        models.append(m);
        continue;
      }
      m["gospa"] = f.gospa;
      m["localization"] = f.localization;
      m["missed"] = f.missed;
      m["false"] = f.false_tracks;
      m["tracks_started_per_scene"] = f.tracks_started;
      m["breaks_per_scene"] = f.breaks;
      m["swaps_per_scene"] = f.swaps;
      m["gospa_minus_first"] = interval(f.versus_first);
      m["per_scene"] = f.per_run;
      models.append(m);
    }
    condition["models"] = models;
    conditions.append(condition);
  }
  return conditions;
}

void require_runs(const std::optional<int>& runs) {
  if (runs && *runs < 1) {
    throw imm::InvalidParameter("runs", "must be ≥ 1 (got " + std::to_string(*runs) + ")");
  }
}

py::dict track_arrays(const imm::datasets::TrackSet& set) {
  const auto tracks = static_cast<py::ssize_t>(set.tracks.size());
  const py::ssize_t scans = set.scans;
  py::array_t<double> truth({tracks, scans, py::ssize_t{6}});
  py::array_t<double> plots({tracks, scans, py::ssize_t{2}});
  py::array_t<bool> maneuvering({tracks, scans});
  py::array_t<int> cases(tracks);
  auto t = truth.mutable_unchecked<3>();
  auto z = plots.mutable_unchecked<3>();
  auto m = maneuvering.mutable_unchecked<2>();
  auto c = cases.mutable_unchecked<1>();
  for (py::ssize_t i = 0; i < tracks; ++i) {
    const imm::datasets::Track& track = set.tracks[static_cast<std::size_t>(i)];
    c(i) = track.case_index;
    for (py::ssize_t k = 0; k < scans; ++k) {
      for (py::ssize_t j = 0; j < 6; ++j) t(i, k, j) = track.truth(k, j);
      for (py::ssize_t j = 0; j < 2; ++j) z(i, k, j) = track.plots(k, j);
      m(i, k) = track.maneuvering[static_cast<std::size_t>(k)];
    }
  }
  py::array_t<double> times(scans);
  for (py::ssize_t k = 0; k < scans; ++k) {
    times.mutable_at(k) = static_cast<double>(k) * set.sample_period;
  }
  py::dict out;
  out["regime"] = set.regime;
  out["split"] = std::string(imm::datasets::to_string(set.split));
  out["seed"] = set.seed;
  out["sample_period"] = set.sample_period;
  out["has_truth"] = set.has_truth;
  out["digest"] = set.digest();
  out["truth"] = truth;
  out["plots"] = plots;
  out["times"] = times;
  out["maneuvering"] = maneuvering;
  out["case"] = cases;
  return out;
}
