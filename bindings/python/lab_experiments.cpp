// SPDX-License-Identifier: Apache-2.0
// evaluate(experiment, …) and rank(…): the experiments of imm-eval through their C++ entry points
// (imm/evaluation/experiments.hpp), with the GIL released, their results as dicts (lab_results.hpp)
// and, with `out`, their reports written as imm-eval writes them.
#include "lab_experiments.hpp"

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>
#include <spdlog/fmt/ranges.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <optional>
#include <streambuf>
#include <string>
#include <type_traits>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/evaluation/evaluation_report.hpp"
#include "imm/evaluation/experiments.hpp"
#include "imm/evaluation/model_experiments.hpp"
#include "lab_results.hpp"

namespace py = pybind11;
namespace fs = std::filesystem;
namespace ev = imm::evaluation;

namespace {

// Takes what is written to it and keeps nothing.
class NullBuffer final : public std::streambuf {
 protected:
  int overflow(int c) override { return traits_type::not_eof(c); }
  std::streamsize xsputn(const char* /*text*/, std::streamsize count) override { return count; }
};

// Runs `body` with std::cout writing nowhere (a report's text, which the files hold).
template <class Body>
void quietly(Body&& body) {
  NullBuffer quiet;
  std::streambuf* console = std::cout.rdbuf(&quiet);
  try {
    body();
  } catch (...) {
    std::cout.rdbuf(console);
    throw;
  }
  std::cout.rdbuf(console);
}

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
      quietly([&] {
        std::vector<const char*> argv;
        argv.reserve(command.size());
        for (const std::string& argument : command) argv.push_back(argument.c_str());
        ev::ReportRecorder recorder(static_cast<int>(argv.size()), argv.data());
        (void)report(result, options);
        written = recorder.finish();
      });
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

// An experiment's own options as keywords of evaluate(): each one given is cast to its type and
// checked against its choices (a TypeError or ValueError naming the keyword); the keys it declares
// are the ones allowed.
class KeywordOptions final : public ev::OptionDeclarer {
 public:
  KeywordOptions(const std::string& experiment, const py::kwargs& given)
      : experiment_(experiment), given_(given) {}
  void text(const char* /*flag*/, const char* key, const char* /*help*/, std::string& value,
            const std::vector<std::string>& choices) override {
    take(key, value);
    if (!choices.empty() && std::find(choices.begin(), choices.end(), value) == choices.end()) {
      throw imm::InvalidParameter(
          key, fmt::format("'{}' is none of {}", value, fmt::join(choices, ", ")));
    }
  }
  void path(const char* /*flag*/, const char* key, const char* /*help*/, fs::path& value) override {
    take(key, value);
  }
  // A TypeError for a keyword the experiment does not declare.
  void check_given() const {
    for (const auto& [key, value] : given_) {
      const std::string name = py::str(key).cast<std::string>();
      if (std::find(allowed_.begin(), allowed_.end(), name) == allowed_.end()) {
        throw py::type_error("evaluate('" + experiment_ + "'): no option '" + name + "'");
      }
    }
  }

 private:
  template <class T>
  void take(const char* key, T& target) {
    allowed_.emplace_back(key);
    if (given_.contains(key)) target = given_[key].cast<T>();
  }
  std::string experiment_;
  const py::kwargs& given_;
  std::vector<std::string> allowed_;
};

// An experiment's own options as the imm-eval arguments that give them (an empty text: left out).
class CommandLineArguments final : public ev::OptionDeclarer {
 public:
  void text(const char* flag, const char* /*key*/, const char* /*help*/, std::string& value,
            const std::vector<std::string>& /*choices*/) override {
    if (!value.empty()) arguments.insert(arguments.end(), {flag, value});
  }
  void path(const char* flag, const char* /*key*/, const char* /*help*/, fs::path& value) override {
    if (!value.empty()) arguments.insert(arguments.end(), {flag, value.string()});
  }
  std::vector<std::string> arguments;
};

py::dict evaluate(const std::string& experiment, const std::optional<fs::path>& model,
                  const fs::path& models, const std::optional<fs::path>& regime,
                  std::optional<int> runs, std::uint64_t seed,
                  const std::optional<fs::path>& classical, bool truth_tracks,
                  const std::optional<fs::path>& out, const py::kwargs& extra) {
  require_runs(runs);
  std::optional<py::dict> result;
  ev::for_each_model_experiment([&](const auto& e) {
    if (result || experiment != e.name) return;
    typename std::remove_cvref_t<decltype(e)>::Options o;
    ev::CommonOptions& c = o.common;
    if (model) c.model = model->string();
    c.models = models;
    c.regime = regime;
    c.runs = runs;
    c.seed = seed;
    c.classical = classical;
    c.truth_tracks = truth_tracks;
    if (out) c.out = *out;
    KeywordOptions keywords(experiment, extra);
    CommandLineArguments arguments;
    if (e.declare != nullptr) {
      e.declare(keywords, o);
      e.declare(arguments, o);
    }
    keywords.check_given();
    result = run(o, e.evaluate, e.report,
                 out ? command_of(experiment, c, arguments.arguments) : std::vector<std::string>{});
  });
  if (!result) {
    throw imm::InvalidParameter("experiment",
                                fmt::format("'{}' is none of {}", experiment,
                                            fmt::join(ev::model_experiment_names(), ", ")));
  }
  return *result;
}

// evaluate()'s help: its experiments and each one's own keywords, from the experiments' list.
std::string evaluate_help() {
  // Each option's keyword, as an experiment declares it.
  struct Keys final : ev::OptionDeclarer {
    void text(const char* /*flag*/, const char* key, const char* /*help*/, std::string&,
              const std::vector<std::string>& /*choices*/) override {
      keys.emplace_back(key);
    }
    void path(const char* /*flag*/, const char* key, const char* /*help*/, fs::path&) override {
      keys.emplace_back(key);
    }
    std::vector<std::string> keys;
  };
  std::vector<std::string> keywords;
  ev::for_each_model_experiment([&](const auto& e) {
    Keys declared;
    typename std::remove_cvref_t<decltype(e)>::Options o;
    if (e.declare != nullptr) e.declare(declared, o);
    if (!declared.keys.empty()) {
      keywords.push_back(fmt::format("{} ({})", fmt::join(declared.keys, " and "), e.name));
    }
  });
  const std::string names = fmt::format("{}", fmt::join(ev::model_experiment_names(), ", "));
  return "Runs an imm-eval experiment (" + names +
         ") with the command's options and returns its result: every filter's figures, the "
         "paired differences [estimate, lower, upper], the gates' failures, the findings and the "
         "exit code imm-eval would give. With `out`, also writes the report there as imm-eval "
         "does, report.md included (its path in \"report\"), without printing it. Its own options "
         "by keyword: " +
         fmt::format("{}", fmt::join(keywords, ", "));
}

}  // namespace

void add_experiments(py::module_& m) {
  m.def("evaluate", &evaluate, py::arg("experiment"), py::kw_only(), py::arg("model") = py::none(),
        py::arg("models") = fs::path("models"), py::arg("regime") = py::none(),
        py::arg("runs") = py::none(), py::arg("seed") = 1, py::arg("classical") = py::none(),
        py::arg("truth_tracks") = false, py::arg("out") = py::none(), evaluate_help().c_str());
  m.def(
      "multi_target",
      [](const std::vector<fs::path>& models, const std::optional<fs::path>& regime,
         std::optional<int> targets, const std::vector<double>& pd,
         const std::vector<double>& clutter, int runs, std::uint64_t seed,
         const std::optional<fs::path>& out) {
        if (models.empty())
          throw imm::InvalidParameter("models", "at least one model file is needed");
        require_runs(runs);
        ev::MultiTargetOptions o;
        o.models = models;
        o.regime = regime;
        o.targets = targets;
        o.detection_probabilities = pd;
        o.clutter_densities = clutter;
        o.settings.runs = runs;
        o.settings.seed = seed;
        if (out) o.out = *out;
        ev::MultiTargetConditions result;
        {
          const py::gil_scoped_release release;
          result = ev::evaluate_multi_target(o);
          if (out) quietly([&] { (void)ev::report_multi_target(result, o); });
        }
        return to_list(result);
      },
      py::arg("models"), py::kw_only(), py::arg("regime") = py::none(),
      py::arg("targets") = py::none(), py::arg("pd") = std::vector<double>{},
      py::arg("clutter") = std::vector<double>{}, py::arg("runs") = 20, py::arg("seed") = 1,
      py::arg("out") = py::none(),
      "imm-eval multi-target: scenes of several targets of the regime among Poisson clutter, "
      "tracked by the reference GNN tracker with each model, on the same scenes; every detection "
      "probability (pd) with every clutter density (clutter: mean false plots per scan over the "
      "region; none given: the regime's [scene]). A dict per condition: each model's GOSPA "
      "(lengths in the regime's unit) with its localization, missed and false parts, tracks "
      "started, breaks and swaps per scene, and its GOSPA − the first model's [estimate, lower, "
      "upper]. With `out`, metrics.json there");
  m.def(
      "rank",
      [](const std::vector<fs::path>& baselines, const std::vector<fs::path>& candidates,
         const std::vector<fs::path>& evaluations, const std::optional<fs::path>& regime,
         std::optional<int> runs, std::uint64_t seed, const std::optional<fs::path>& out,
         const std::optional<fs::path>& ship, bool raw_ship) {
        if (baselines.empty()) throw imm::InvalidParameter("baselines", "at least one is needed");
        require_runs(runs);
        if (ship && !out)
          throw imm::InvalidParameter("ship", "needs out (tracker.json records it)");
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
