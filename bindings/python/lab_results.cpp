// SPDX-License-Identifier: Apache-2.0
// Every experiment's typed result as a dict: what it shares (ExperimentResult) under the same keys
// for every experiment, and its own tables under theirs. Differences are [estimate, lower, upper]
// (the 95 % paired-bootstrap interval), as in metrics.json.
#include "lab_results.hpp"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <streambuf>
#include <string>
#include <type_traits>
#include <vector>

#include "imm/evaluation/evaluation_report.hpp"
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

// Takes what is written to it and keeps nothing.
class NullBuffer final : public std::streambuf {
 protected:
  int overflow(int c) override { return traits_type::not_eof(c); }
  std::streamsize xsputn(const char* /*text*/, std::streamsize count) override { return count; }
};

// Runs `evaluate` with the GIL released; with a `command` (the imm-eval command line that gives the
// same result), then the report into the options' folder as imm-eval writes it, report.md
// included, without printing it. The result's "report" is report.md's path (None without).
template <class Options, class Result>
py::dict run(Options options, Result (*evaluate)(const Options&),
             int (*report)(const Result&, const Options&),
             const std::vector<std::string>& command) {
  Result result;
  fs::path written;
  {
    const py::gil_scoped_release release;
    result = evaluate(options);
    if (!command.empty()) {
      NullBuffer quiet;
      std::streambuf* console = std::cout.rdbuf(&quiet);
      try {
        std::vector<const char*> argv;
        argv.reserve(command.size());
        for (const std::string& argument : command) argv.push_back(argument.c_str());
        ev::ReportRecorder recorder(static_cast<int>(argv.size()), argv.data());
        (void)report(result, options);
        written = recorder.finish();
      } catch (...) {
        std::cout.rdbuf(console);
        throw;
      }
      std::cout.rdbuf(console);
    }
  }
  py::dict out = to_dict(result);
  out["report"] = written.empty() ? py::none() : py::cast(written);
  return out;
}

// The imm-eval command line of an experiment's options: what report.md says ran.
std::vector<std::string> command_of(const std::string& experiment, const ev::CommonOptions& c,
                                    const std::vector<std::string>& more) {
  std::vector<std::string> command = {"imm-eval",        experiment, "--models",
                                      c.models.string(), "--model",  c.model};
  if (c.regime) command.insert(command.end(), {"--regime", c.regime->string()});
  if (c.runs) command.insert(command.end(), {"--runs", std::to_string(*c.runs)});
  command.insert(command.end(), {"--seed", std::to_string(c.seed)});
  if (c.classical) command.insert(command.end(), {"--classical", c.classical->string()});
  if (c.truth_tracks) command.emplace_back("--truth-tracks");
  command.insert(command.end(), more.begin(), more.end());
  command.insert(command.end(), {"--out", c.out.string()});
  return command;
}

py::dict evaluate(const std::string& experiment, const std::optional<fs::path>& model,
                  const fs::path& models, const std::optional<fs::path>& regime,
                  std::optional<int> runs, std::uint64_t seed,
                  const std::optional<fs::path>& classical, bool truth_tracks,
                  const std::optional<fs::path>& out, const py::kwargs& extra) {
  if (runs && *runs < 1)
    throw py::value_error("runs: must be ≥ 1 (got " + std::to_string(*runs) + ")");
  const auto fill = [&](ev::CommonOptions& c) {
    if (model) c.model = model->string();
    c.models = models;
    c.regime = regime;
    c.runs = runs;
    c.seed = seed;
    c.classical = classical;
    c.truth_tracks = truth_tracks;
    if (out) c.out = *out;
  };
  std::vector<std::string> allowed;
  const auto take = [&](const char* key, auto& target) {
    allowed.emplace_back(key);
    if (extra.contains(key)) target = extra[key].cast<std::remove_reference_t<decltype(target)>>();
  };
  const auto check_extra = [&] {
    for (const auto& [key, value] : extra) {
      const std::string name = py::str(key).cast<std::string>();
      if (std::find(allowed.begin(), allowed.end(), name) == allowed.end()) {
        std::string message = "evaluate('" + experiment + "'): no option '";
        message.append(name).append("'");
        throw py::type_error(message);
      }
    }
  };
  const bool write = out.has_value();
  const auto command = [&](const std::string& name, const ev::CommonOptions& c,
                           const std::vector<std::string>& more = {}) {
    return write ? command_of(name, c, more) : std::vector<std::string>{};
  };
  if (experiment == "plain-imm") {
    ev::PlainImmOptions o;
    fill(o.common);
    take("data", o.data);
    check_extra();
    return run(o, ev::evaluate_plain_imm, ev::report_plain_imm,
               command(experiment, o.common,
                       o.data.empty() ? std::vector<std::string>{}
                                      : std::vector<std::string>{"--data", o.data}));
  }
  if (experiment == "ga-imm") {
    ev::GaImmOptions o;
    fill(o.common);
    take("paper_model", o.paper_model);
    check_extra();
    return run(o, ev::evaluate_ga_imm, ev::report_ga_imm,
               command(experiment, o.common, {"--paper-model", o.paper_model}));
  }
  if (experiment == "input-estimator") {
    ev::InputEstimatorOptions o;
    fill(o.common);
    check_extra();
    return run(o, ev::evaluate_input_estimator, ev::report_input_estimator,
               command(experiment, o.common));
  }
  if (experiment == "wimm") {
    ev::WimmOptions o;
    fill(o.common);
    check_extra();
    return run(o, ev::evaluate_wimm, ev::report_wimm, command(experiment, o.common));
  }
  if (experiment == "fcm-imm") {
    ev::FcmImmOptions o;
    fill(o.common);
    check_extra();
    return run(o, ev::evaluate_fcm_imm, ev::report_fcm_imm, command(experiment, o.common));
  }
  if (experiment == "fimm") {
    ev::FimmOptions o;
    fill(o.common);
    take("config", o.config);
    take("gate_on", o.gate_on);
    check_extra();
    if (o.gate_on != "ekf" && o.gate_on != "best") {
      throw py::value_error("gate_on: '" + o.gate_on + "' is neither ekf nor best");
    }
    return run(
        o, ev::evaluate_fimm, ev::report_fimm,
        command(experiment, o.common, {"--config", o.config.string(), "--gate-on", o.gate_on}));
  }
  throw py::value_error("experiment: '" + experiment +
                        "' is none of plain-imm, ga-imm, input-estimator, wimm, fcm-imm, fimm");
}

}  // namespace

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

void add_experiments(py::module_& m) {
  m.def("evaluate", &evaluate, py::arg("experiment"), py::kw_only(), py::arg("model") = py::none(),
        py::arg("models") = fs::path("models"), py::arg("regime") = py::none(),
        py::arg("runs") = py::none(), py::arg("seed") = 1, py::arg("classical") = py::none(),
        py::arg("truth_tracks") = false, py::arg("out") = py::none(),
        "Runs an imm-eval experiment (plain-imm, ga-imm, input-estimator, wimm, fcm-imm, fimm) "
        "with the command's options and returns its result: every filter's figures, the paired "
        "differences [estimate, lower, upper], the gates' failures, the findings and the exit "
        "code imm-eval would give. With `out`, also writes the report there as imm-eval does, "
        "report.md included (its path in \"report\"), without printing it. Its own options by "
        "keyword: data (plain-imm), paper_model (ga-imm), "
        "config and gate_on (fimm)");
  m.def(
      "rank",
      [](const std::vector<fs::path>& baselines, const std::vector<fs::path>& candidates,
         const std::vector<fs::path>& evaluations, const std::optional<fs::path>& regime,
         std::optional<int> runs, std::uint64_t seed, const std::optional<fs::path>& out,
         const std::optional<fs::path>& ship, bool raw_ship) {
        if (baselines.empty()) throw py::value_error("baselines: at least one is needed");
        if (runs && *runs < 1) {
          throw py::value_error("runs: must be ≥ 1 (got " + std::to_string(*runs) + ")");
        }
        if (ship && !out) throw py::value_error("ship: needs out (tracker.json records it)");
        ev::RankOptions o;
        o.baselines = baselines;
        o.candidates = candidates;
        o.evaluations = evaluations;
        o.regime = regime;
        o.runs = runs;
        o.seed = seed;
        if (out) o.out = *out;
        o.ship = ship;
        o.raw_ship = raw_ship;
        std::vector<std::string> command;
        if (out) {
          command = {"imm-eval", "rank", "--baseline"};
          for (const fs::path& b : baselines) command.push_back(b.string());
          command.emplace_back("--candidates");
          for (const fs::path& c : candidates) command.push_back(c.string());
          if (!evaluations.empty()) command.emplace_back("--evaluations");
          for (const fs::path& e : evaluations) command.push_back(e.string());
          if (regime) command.insert(command.end(), {"--regime", regime->string()});
          if (runs) command.insert(command.end(), {"--runs", std::to_string(*runs)});
          command.insert(command.end(), {"--seed", std::to_string(seed), "--out", out->string()});
          if (ship) command.insert(command.end(), {"--ship", ship->string()});
          if (raw_ship) command.emplace_back("--raw-ship");
        }
        return run(o, ev::evaluate_rank, ev::report_rank, command);
      },
      py::arg("baselines"), py::arg("candidates"), py::kw_only(),
      py::arg("evaluations") = std::vector<fs::path>{}, py::arg("regime") = py::none(),
      py::arg("runs") = py::none(), py::arg("seed") = 1, py::arg("out") = py::none(),
      py::arg("ship") = py::none(), py::arg("raw_ship") = false,
      "The regime's tracker, as imm-eval rank: the baselines and the candidates ranked on the "
      "test split; with `out`, tracker.json there, and with `ship` the winner written (with its "
      "covariance calibration unless raw_ship)");
}
