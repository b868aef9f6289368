// SPDX-License-Identifier: Apache-2.0
// The Python module `immtrain_lab`: the trainer's side of immtrain — regimes, their tracks, the
// experiments of imm-eval and the trainings of imm-train — as Python calls into the C++ libraries
// (never the command-line tools).
// `immtrain` imports it on first use of one of its names (immtrain.load_regime, immtrain.evaluate,
// …), so that a program that only tracks loads the runtime alone.
//
//   import immtrain
//   regime = immtrain.load_regime("configs/regimes/agile_air.toml")
//   tracks = regime.draw("test", runs=20)          # numpy arrays: truth, plots, times, …
//   result = immtrain.evaluate("ga-imm", model="models/ga_fuzzy_imm_agile_air.h5", runs=20)
//   result["filters"]["GA-IMM"]["zeta_p"], result["findings"], result["exit_code"]
//   trained = immtrain.train("ga", config="configs/ga_fuzzy_imm.toml", seed=3, out="mine.h5")

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <vector>

#include "imm/build_info.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/dataset_file.hpp"
#include "imm/datasets/recorded.hpp"
#include "imm/datasets/regime_file.hpp"
#include "imm/datasets/track.hpp"
#include "imm/evaluation/experiments.hpp"
#include "imm/io/file_error.hpp"
#include "imm/support/config.hpp"
#include "lab_experiments.hpp"
#include "lab_results.hpp"
#include "lab_training.hpp"

namespace py = pybind11;
namespace fs = std::filesystem;

namespace {

using imm::datasets::RegimeFile;

// `text` as a TOML basic string: quoted, with ", \ and every control character escaped (TOML
// allows none raw but tab; a newline would end the line).
std::string toml_string(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') {
      out.push_back('\\');
      out.push_back(c);
    } else if (byte < 0x20 || byte == 0x7f) {
      constexpr char kHex[] = "0123456789ABCDEF";
      out += "\\u00";
      out.push_back(kHex[byte >> 4U]);
      out.push_back(kHex[byte & 0xfU]);
    } else {
      out.push_back(c);
    }
  }
  return out + "\"";
}

// A dict key as a TOML key: bare where TOML allows it (letters, digits, _ and -), quoted
// otherwise, so that a key with a dot, a space or an = stays one key.
std::string toml_key(const py::handle& key) {
  const std::string name = py::str(key).cast<std::string>();
  const bool bare = !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '-';
  });
  return bare ? name : toml_string(name);
}

// A value of a regime dict as TOML: numbers, booleans, strings and arrays of them.
std::string toml_value(const py::handle& value, const std::string& key) {
  if (py::isinstance<py::bool_>(value)) return value.cast<bool>() ? "true" : "false";
  if (py::isinstance<py::int_>(value)) {
    try {
      return std::to_string(value.cast<long long>());
    } catch (const py::cast_error&) {
      throw py::value_error(key + ": an integer beyond 64 bits");
    }
  }
  if (py::isinstance<py::float_>(value)) return py::repr(value).cast<std::string>();
  if (py::isinstance<py::str>(value)) return toml_string(value.cast<std::string>());
  if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value)) {
    std::string text = "[";
    std::size_t i = 0;
    for (const py::handle item : value) {
      text += (i == 0 ? "" : ", ") + toml_value(item, key + "[" + std::to_string(i) + "]");
      ++i;
    }
    return text + "]";
  }
  throw py::value_error(key +
                        ": a regime value is a number, a boolean, a string or a list of them");
}

bool is_table_array(const py::handle& value) {
  if (!py::isinstance<py::list>(value) && !py::isinstance<py::tuple>(value)) return false;
  if (py::len(value) == 0) return false;
  for (const py::handle item : value) {
    if (!py::isinstance<py::dict>(item)) return false;
  }
  return true;
}

// A dict as a TOML document: its values, then its tables ([name]) and arrays of tables
// ([[name]]), nested under `prefix`.
void toml_table(const py::dict& table, const std::string& prefix, std::string& text) {
  for (const auto& [key, value] : table) {
    if (py::isinstance<py::dict>(value) || is_table_array(value)) continue;
    text +=
        toml_key(key) + " = " + toml_value(value, prefix + py::str(key).cast<std::string>()) + "\n";
  }
  for (const auto& [key, value] : table) {
    const std::string name = prefix + toml_key(key);
    if (py::isinstance<py::dict>(value)) {
      text += "\n[" + name + "]\n";
      toml_table(value.cast<py::dict>(), name + ".", text);
    } else if (is_table_array(value)) {
      for (const py::handle item : value) {
        text += "\n[[" + name + "]]\n";
        toml_table(item.cast<py::dict>(), name + ".", text);
      }
    }
  }
}

// A regime and the text it was read from.
struct PyRegime {
  RegimeFile file;
  std::string text;

  [[nodiscard]] py::dict draw(const std::string& split_name, std::optional<std::uint64_t> seed,
                              std::optional<int> runs) const {
    const imm::datasets::Regime& regime = file.regime;
    const imm::datasets::Split split = imm::datasets::split_named(split_name, "split");
    require_runs(runs);
    imm::datasets::TrackSet set;
    {
      const py::gil_scoped_release release;
      set = imm::datasets::draw_split(regime, split, seed.value_or(regime.splits.seed),
                                      runs.value_or(-1));
    }
    return track_arrays(set);
  }
};

PyRegime regime_from_text(std::string text, const std::string& name) {
  return {imm::datasets::parse_regime(text, name), std::move(text)};
}

}  // namespace

PYBIND11_MODULE(immtrain_lab, m) {
  m.doc() =
      "immtrain's trainer side: regimes, their tracks, the experiments of imm-eval and the "
      "trainings of imm-train (imported by immtrain on first use)";
  // The runtime's errors raise immtrain's own classes here too (immtrain.InvalidParameter, a
  // ValueError; immtrain.FileError, a RuntimeError). The translator is this module's alone: a
  // process-wide one, registered on first use of a lab name, would come before immtrain's and
  // turn immtrain's own errors into plain ValueErrors from then on. The classes outlive the
  // interpreter's teardown on purpose (released, never decremented).
  static const py::handle invalid_parameter =
      py::object(py::module_::import("immtrain").attr("InvalidParameter")).release();
  static const py::handle file_error =
      py::object(py::module_::import("immtrain").attr("FileError")).release();
  py::register_local_exception_translator(
      [](std::exception_ptr p) {  // NOLINT(performance-unnecessary-value-param)
        try {
          if (p) std::rethrow_exception(p);
        } catch (const imm::support::ConfigError& e) {
          PyErr_SetString(PyExc_ValueError, e.what());
        } catch (const imm::InvalidParameter& e) {
          PyErr_SetString(invalid_parameter.ptr(), e.what());
        } catch (const imm::io::FileError& e) {
          PyErr_SetString(file_error.ptr(), e.what());
        }
      });

  py::class_<PyRegime>(m, "Regime", "A regime: what a filter is trained and judged for")
      .def_property_readonly("name", [](const PyRegime& r) { return r.file.regime.name; })
      .def_property_readonly(
          "units",
          [](const PyRegime& r) {
            return std::string(imm::datasets::to_string(r.file.regime.units));
          },
          "the length unit: m or km")
      .def_property_readonly(
          "sample_period", [](const PyRegime& r) { return r.file.regime.sample_period; }, "T, s")
      .def_property_readonly(
          "scans", [](const PyRegime& r) { return r.file.regime.scans; }, "scans per track")
      .def_property_readonly(
          "digest", [](const PyRegime& r) { return r.file.regime.digest; },
          "SHA-256 of the regime's text")
      .def_property_readonly(
          "splits",
          [](const PyRegime& r) {
            const imm::datasets::Splits& s = r.file.regime.splits;
            py::dict splits;
            splits["training"] = s.training;
            splits["validation"] = s.validation;
            splits["test"] = s.test;
            splits["seed"] = s.seed;
            return splits;
          },
          "tracks per split and the seed of the training and validation splits")
      .def_property_readonly(
          "cases",
          [](const PyRegime& r) {
            std::vector<std::string> names;
            names.reserve(static_cast<std::size_t>(r.file.regime.case_count()));
            for (int c = 0; c < r.file.regime.case_count(); ++c) {
              names.push_back(r.file.regime.case_name(c));
            }
            return names;
          },
          "the scripted cases' names (one empty name for a random regime)")
      .def_property_readonly(
          "toml", [](const PyRegime& r) { return r.text; },
          "the regime's TOML text (write it to a file to use it with the tools)")
      .def("draw", &PyRegime::draw, py::arg("split") = "test", py::arg("seed") = py::none(),
           py::arg("runs") = py::none(),
           "Draws a split's tracks as imm-data does (seed: the test split's seed, default the "
           "regime's splits.seed; runs: how many, default the split's size). Returns numpy "
           "arrays: truth (tracks × scans × 6: x, vx, ax, y, vy, ay), plots (tracks × scans × 2), "
           "times (scans, s), maneuvering (tracks × scans), case (tracks)")
      .def("__repr__", [](const PyRegime& r) {
        return "<immtrain.Regime " + r.file.regime.name + " (" +
               std::string(imm::datasets::to_string(r.file.regime.units)) + ", T " +
               py::repr(py::float_(r.file.regime.sample_period)).cast<std::string>() + " s)>";
      });

  m.def(
      "load_regime",
      [](const fs::path& path) {
        PyRegime regime{imm::datasets::load_regime(path), {}};
        std::ifstream in(path);
        regime.text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
        return regime;
      },
      py::arg("path"),
      "Reads and validates a regime file; ValueError naming the file and the key when invalid");
  m.def(
      "regime_from_dict",
      [](const py::dict& table, const std::string& name) {
        std::string text;
        toml_table(table, "", text);
        return regime_from_text(std::move(text), name);
      },
      py::arg("table"), py::arg("name") = "<dict>",
      "A regime from a dict shaped like a regime file (nested dicts for its tables, lists of dicts "
      "for [[maneuvers]]), validated as a file is: ValueError naming the key");
  m.def(
      "import_recordings",
      [](const std::vector<fs::path>& files, const fs::path& out, const std::string& name,
         const std::string& sensor, const std::string& units, double sample_period,
         double tolerance, int scans) {
        imm::datasets::ImportOptions options;
        options.name = name;
        options.kind = imm::datasets::sensor_kind_named(sensor, "sensor");
        options.units = imm::datasets::units_named(units, "units");
        if (!(sample_period >= 0.0) || !std::isfinite(sample_period)) {
          throw imm::InvalidParameter("sample_period",
                                      "must be ≥ 0 s (0: the first track's median step)");
        }
        if (!(tolerance >= 1e-9 && tolerance <= 0.49)) {
          throw imm::InvalidParameter("tolerance", "must lie in [1e-9, 0.49] of a sample period");
        }
        if (scans != 0 && scans < 3)
          throw imm::InvalidParameter("scans", "must be ≥ 3 (0: the shortest)");
        if (files.empty()) throw imm::InvalidParameter("files", "at least one recording is needed");
        options.sample_period = sample_period;
        options.tolerance = tolerance;
        options.scans = scans;
        imm::datasets::ImportReport report;
        imm::datasets::TrackSet set;
        std::string digest;
        {
          const py::gil_scoped_release release;
          set = imm::datasets::import_recording_files(files, options, &report);
          if (out.has_parent_path()) fs::create_directories(out.parent_path());
          digest = imm::datasets::write_track_set(
              out, imm::datasets::recording_header(options, set), set, imm::kBuildVersion);
        }
        py::dict result;
        result["file"] = out;
        result["digest"] = digest;
        result["recordings"] = report.recordings;
        result["windows"] = report.windows;
        result["scans"] = report.scans;
        result["sample_period"] = report.sample_period;
        result["gap_scans"] = report.gap_scans;
        result["dropped_scans"] = report.dropped_scans;
        result["repeated_lines"] = report.repeated_lines;
        result["tracks"] = track_arrays(set);
        return result;
      },
      py::arg("files"), py::kw_only(), py::arg("out"), py::arg("name") = "recorded",
      py::arg("sensor") = "cartesian", py::arg("units") = "m", py::arg("sample_period") = 0.0,
      py::arg("tolerance") = 0.05, py::arg("scans") = 0,
      "Imports recorded tracks (CSV files, or folders of them: t, the plots, optional truth; "
      "docs/regimes.md) into a track set file `out`, as imm-data import does, and returns what it "
      "did and the tracks as numpy arrays. sample_period in s (0: the first track's median step), "
      "tolerance in sample periods, scans per window (0: the shortest track). A bad file is a "
      "RuntimeError naming the file, line and column");
  add_experiments(m);
  add_training(m);
}
