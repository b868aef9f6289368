// SPDX-License-Identifier: Apache-2.0
// The Python module `immtrain`: the runtime (imm::runtime) as Python objects — a model file's
// tracker, a plain or GA-fuzzy IMM's track bank, and what a model file holds. A client of the
// runtime alone, like imm-track: the same calls, so the same numbers to the bit.
//
//   import immtrain
//   tracker = immtrain.load_tracker("models/ga_fuzzy_imm.h5")
//   out = tracker.run(plots)          # plots: (N, 3) array of k, z1, z2
//   out["mean"], out["covariance"], out["mode_probabilities"], out["outside_envelope"]
//
// Errors keep the C++ message (file and field): immtrain.FileError for a model file that cannot be
// read, immtrain.InvalidParameter (a ValueError) for invalid settings or plots of the wrong shape.

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "filter_binding.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/io/container_file.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "imm/io/file_error.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/io/wimm_file.hpp"
#include "imm/load.hpp"
#include "imm/model_kinds.hpp"
#include "imm/tracking/tracker.hpp"
#include "imm/version.hpp"

namespace py = pybind11;
namespace fs = std::filesystem;

namespace {

py::object attribute_value(const imm::io::Attribute& value) {
  if (const auto* i = std::get_if<std::int64_t>(&value)) return py::int_(*i);
  if (const auto* d = std::get_if<double>(&value)) return py::float_(*d);
  return py::str(std::get<std::string>(value));
}

py::dict attributes_of(const imm::io::ContainerReader& file, const std::string& path) {
  py::dict attributes;
  for (const std::string& name : file.attribute_names(path)) {
    attributes[py::str(name)] = attribute_value(*file.attribute(path, name));
  }
  return attributes;
}

// Every group and dataset under `group`, by path: {"attributes": {...}, "values": ndarray}.
void collect(const imm::io::ContainerReader& file, const std::string& group, py::dict& objects) {
  for (const std::string& name : file.children(group)) {
    std::string path = group == "/" ? std::string() : group;
    path.append("/").append(name);
    py::dict object;
    object["attributes"] = attributes_of(file, path);
    if (file.kind(path) == imm::io::ObjectKind::kGroup) {
      objects[py::str(path)] = object;
      collect(file, path, objects);
      continue;
    }
    const imm::io::Array array = file.read(path);
    std::vector<py::ssize_t> shape(array.shape.begin(), array.shape.end());
    py::array_t<double> values(shape);
    std::copy(array.values.begin(), array.values.end(), values.mutable_data());
    object["values"] = values;
    objects[py::str(path)] = object;
  }
}

py::dict provenance_of(const imm::io::Provenance& p) {
  py::dict d;
  d["model_kind"] = p.model_kind;
  d["created_utc"] = p.created_utc;
  d["trainer_version"] = p.trainer_version;
  d["seed"] = p.seed;
  d["config_toml"] = p.config_toml;
  d["dataset_digest"] = p.dataset_digest;
  d["regime_name"] = p.regime_name;
  d["regime_toml"] = p.regime_toml;
  d["regime_digest"] = p.regime_digest;
  d["length_unit"] = p.length_unit;
  d["training_metrics"] = p.training_metrics;
  d["validation_metrics"] = p.validation_metrics;
  return d;
}

// inspect(path): what the file holds, as Python objects.
py::dict inspect(const fs::path& path) {
  const imm::io::ModelFileReader reader(path);
  const imm::io::ContainerReader& file = reader.container();
  py::dict units;
  for (const std::string& object : file.objects()) {
    if (const auto u = file.attribute(object, "units");
        u && std::holds_alternative<std::string>(*u))
      units[py::str(object)] = std::get<std::string>(*u);
  }
  py::dict objects;
  collect(file, "/", objects);
  py::dict d;
  d["file"] = path.string();
  d["kind"] = reader.provenance().model_kind;
  d["schema_version"] = reader.schema_version();
  d["regime"] = reader.provenance().regime_name;
  d["provenance"] = provenance_of(reader.provenance());
  d["attributes"] = attributes_of(file, "/");
  d["units"] = units;
  d["parameters"] = objects;
  return d;
}

// verify(path): every check imm-inspect --verify makes on a model file; raises on the first.
py::dict verify(const fs::path& path) {
  const imm::io::ModelFileReader reader(path);
  (void)imm::load_filter(reader);  // every field of its kind, and the filter it builds
  py::dict d;
  d["file"] = path.string();
  d["kind"] = reader.provenance().model_kind;
  d["schema_version"] = reader.schema_version();
  d["ok"] = true;
  return d;
}

// One model file's track, with its filter's names (imm-track's columns).
class PyTracker {
 public:
  PyTracker(const fs::path& path, std::int64_t max_gap) {
    imm::LoadedFilter loaded = imm::load_filter(path, max_gap);
    provenance_ = loaded.provenance;
    options_ = loaded.options;
    for (int j = 0; j < loaded.filter->mode_count(); ++j) {
      modes_.push_back(loaded.filter->mode_name(j));
    }
    tracker_ = std::make_unique<imm::Tracker>(std::move(loaded.filter), loaded.options);
  }

  py::dict process(std::int64_t scan, const Eigen::Vector2d& z) {
    return result_dict(tracker_->process(scan, z));
  }
  py::dict process_at(double time, const Eigen::Vector2d& z) {
    return result_dict(tracker_->process_at(time, z));
  }

  static py::dict result_dict(const imm::TrackStepResult& r) {
    py::dict d;
    d["event"] = std::string(imm::to_string(r.event));
    d["status"] = std::string(imm::to_string(r.status));
    d["predicted_scans"] = r.predicted_scans;
    d["reason"] = std::string(r.reason);
    d["outside_envelope"] = r.outside_envelope;
    d["envelope_nis"] = r.envelope_nis;
    return d;
  }

  // The whole track in one call: plots is (N, 3) of k, z1, z2 (rows in scan order). Rows before
  // the track starts (and after it ends) have NaN estimates.
  py::dict run(const py::array_t<double, py::array::c_style | py::array::forcecast>& plots) {
    if (plots.ndim() != 2 || plots.shape(1) != 3) {
      throw imm::InvalidParameter(
          "plots", "expected an (N, 3) array of k, z1, z2, got " + shape_text(plots));
    }
    const auto n = static_cast<py::ssize_t>(state_dimension());
    const auto m = static_cast<py::ssize_t>(mode_count());
    const py::ssize_t rows = plots.shape(0);
    py::array_t<double> mean({rows, n}), covariance({rows, n, n}), mu({rows, m}), nis(rows);
    py::array_t<bool> outside(rows);
    py::list events;
    const auto p = plots.unchecked<2>();
    // Every scan is checked before the first plot is fed: a bad array changes nothing.
    for (py::ssize_t i = 0; i < rows; ++i) {
      const double k = p(i, 0);
      if (!std::isfinite(k) || k != std::floor(k) || std::abs(k) > 9.0e15) {
        throw imm::InvalidParameter("plots[" + std::to_string(i) + ", 0]",
                                    "the scan k must be a whole number");
      }
    }
    auto mean_out = mean.mutable_unchecked<2>();
    auto cov_out = covariance.mutable_unchecked<3>();
    auto mu_out = mu.mutable_unchecked<2>();
    auto nis_out = nis.mutable_unchecked<1>();
    auto outside_out = outside.mutable_unchecked<1>();
    Eigen::VectorXd x(n), variance(n);
    Eigen::MatrixXd P(n, n);
    std::vector<imm::TrackEvent> event_of(static_cast<std::size_t>(rows));
    {
      // The filter runs without the GIL (other Python threads go on); it touches only the arrays'
      // memory and C++ objects. A Tracker is not to be shared between threads.
      const py::gil_scoped_release release;
      for (py::ssize_t i = 0; i < rows; ++i) {
        const imm::TrackStepResult r = tracker_->process(static_cast<std::int64_t>(p(i, 0)),
                                                         Eigen::Vector2d(p(i, 1), p(i, 2)));
        event_of[static_cast<std::size_t>(i)] = r.event;
        const bool on = tracker_->initialized();
        if (on) {
          tracker_->state(x, variance);
          tracker_->covariance(P);
        }
        const imm::ModeVector probabilities = tracker_->mode_probabilities();
        for (py::ssize_t a = 0; a < n; ++a) {
          mean_out(i, a) = on ? x(a) : NAN;
          for (py::ssize_t b = 0; b < n; ++b) cov_out(i, a, b) = on ? P(a, b) : NAN;
        }
        for (py::ssize_t j = 0; j < m; ++j) mu_out(i, j) = on ? probabilities(j) : NAN;
        nis_out(i) = r.envelope_nis;
        outside_out(i) = r.outside_envelope;
      }
    }
    for (const imm::TrackEvent event : event_of) events.append(std::string(imm::to_string(event)));
    py::dict d;
    d["k"] = plots[py::make_tuple(py::slice(0, rows, 1), 0)];
    d["event"] = events;
    d["mean"] = mean;
    d["covariance"] = covariance;
    d["mode_probabilities"] = mu;
    d["envelope_nis"] = nis;
    d["outside_envelope"] = outside;
    return d;
  }

  [[nodiscard]] int state_dimension() const { return tracker_->state_dimension(); }
  [[nodiscard]] int mode_count() const { return tracker_->mode_count(); }
  [[nodiscard]] std::vector<std::string> state_names() const {
    return imm::state_variable_names(state_dimension());
  }
  [[nodiscard]] const std::vector<std::string>& mode_names() const { return modes_; }
  [[nodiscard]] bool initialized() const { return tracker_->initialized(); }
  [[nodiscard]] py::tuple state() const {
    if (!initialized()) throw imm::InvalidParameter("state", "no track is running yet");
    Eigen::VectorXd x(state_dimension()), variance(state_dimension());
    Eigen::MatrixXd P(state_dimension(), state_dimension());
    tracker_->state(x, variance);
    tracker_->covariance(P);
    return py::make_tuple(x, P);
  }
  [[nodiscard]] Eigen::VectorXd mode_probabilities() const {
    return tracker_->mode_probabilities();
  }
  [[nodiscard]] double sample_period() const { return options_.sample_period; }
  [[nodiscard]] std::string measurement_kind() const {
    return std::string(imm::to_string(options_.measurement_kind));
  }
  [[nodiscard]] std::string length_unit() const { return provenance_.length_unit; }
  [[nodiscard]] Eigen::Matrix2d measurement_covariance() const {
    return options_.measurement_covariance;
  }
  [[nodiscard]] std::string kind() const { return provenance_.model_kind; }
  [[nodiscard]] std::string regime() const { return provenance_.regime_name; }

 private:
  static std::string shape_text(const py::array& a) {
    std::string text = "(";
    for (py::ssize_t i = 0; i < a.ndim(); ++i) text += (i ? ", " : "") + std::to_string(a.shape(i));
    return text + (a.ndim() == 1 ? ",)" : ")");
  }

  std::unique_ptr<imm::Tracker> tracker_;
  imm::io::Provenance provenance_;
  imm::TrackOptions options_;
  std::vector<std::string> modes_;
};

// A model's bank: many tracks stepped by one call, of whatever kind the file holds
// (imm::open_track_bank: the kind's own bank behind imm::AnyTrackBank).
class PyTrackBank {
 public:
  PyTrackBank(const fs::path& path, std::size_t capacity)
      : bank_(imm::open_track_bank(path, capacity)),
        kind_(imm::io::ModelFileReader(path).provenance().model_kind) {}

  // Starts track `track` from a mean and covariance of the bank's state dimension.
  void initialize(std::size_t track, const Eigen::VectorXd& mean, const Eigen::MatrixXd& P) {
    bank_->initialize(track, mean, P);
  }

  // One cycle of tracks 0 … N − 1 with plots (N, 2); returns each track's status.
  bool set_interval(double interval) { return bank_->set_interval(interval); }

  std::vector<std::string> step(
      const py::array_t<double, py::array::c_style | py::array::forcecast>& plots) {
    if (plots.ndim() != 2 || plots.shape(1) != 2) {
      throw imm::InvalidParameter("plots", "expected an (N, 2) array of plots");
    }
    const auto rows = static_cast<std::size_t>(plots.shape(0));
    if (rows > bank_->capacity()) {
      throw imm::InvalidParameter("plots", "expected at most " + std::to_string(bank_->capacity()) +
                                               " rows, one per track, got " + std::to_string(rows));
    }
    plots_.resize(rows);
    status_.resize(rows);
    const auto p = plots.unchecked<2>();
    for (std::size_t t = 0; t < rows; ++t) {
      plots_[t] =
          Eigen::Vector2d(p(static_cast<py::ssize_t>(t), 0), p(static_cast<py::ssize_t>(t), 1));
    }
    {
      const py::gil_scoped_release release;  // the bank's step touches no Python object
      bank_->step(plots_, status_);
    }
    std::vector<std::string> out;
    out.reserve(rows);
    for (const imm::StepStatus s : status_) out.emplace_back(imm::to_string(s));
    return out;
  }

  [[nodiscard]] py::tuple estimate(std::size_t track) const {
    Eigen::VectorXd mean;
    Eigen::MatrixXd covariance;
    bank_->estimate(track, mean, covariance);
    return py::make_tuple(mean, covariance);
  }
  [[nodiscard]] int state_dimension() const { return bank_->state_dimension(); }
  [[nodiscard]] Eigen::VectorXd mode_probabilities(std::size_t track) const {
    return bank_->mode_probabilities(track);
  }
  [[nodiscard]] std::size_t capacity() const { return bank_->capacity(); }
  [[nodiscard]] std::string kind() const { return kind_; }

  // The (tracks, plots) log-likelihoods of candidate plots (M, 2) for tracks 0 … tracks − 1; −inf
  // outside the gate.
  [[nodiscard]] Eigen::MatrixXd candidate_log_likelihoods(
      const py::array_t<double, py::array::c_style | py::array::forcecast>& plots,
      std::size_t tracks, double gate) {
    if (plots.ndim() != 2 || plots.shape(1) != 2) {
      throw imm::InvalidParameter("plots", "expected an (M, 2) array of plots");
    }
    if (tracks > bank_->capacity()) {
      throw imm::InvalidParameter("tracks", "must be at most the bank's " +
                                                std::to_string(bank_->capacity()) +
                                                " tracks, got " + std::to_string(tracks));
    }
    const auto rows = static_cast<std::size_t>(plots.shape(0));
    std::vector<Eigen::Vector2d> candidates(rows);
    const auto p = plots.unchecked<2>();
    for (std::size_t q = 0; q < rows; ++q) {
      candidates[q] =
          Eigen::Vector2d(p(static_cast<py::ssize_t>(q), 0), p(static_cast<py::ssize_t>(q), 1));
    }
    Eigen::MatrixXd out(static_cast<Eigen::Index>(tracks), static_cast<Eigen::Index>(rows));
    {
      const py::gil_scoped_release release;
      bank_->candidate_log_likelihoods(candidates, gate, out);
    }
    return out;
  }

  // Whether the bank states its covariances and gate through the file's calibration.
  [[nodiscard]] bool calibrated() const { return bank_->calibration() != nullptr; }

 private:
  std::unique_ptr<imm::AnyTrackBank> bank_;
  std::string kind_;
  std::vector<Eigen::Vector2d> plots_;
  std::vector<imm::StepStatus> status_;
};

}  // namespace

PYBIND11_MODULE(immtrain, m) {
  m.doc() = "immtrain's runtime: load a model file's tracker and run it over plots";
  m.attr("__version__") = imm::kVersion;
  m.attr("model_schema_version") = imm::kModelSchemaVersion;
  static py::exception<imm::io::FileError> file_error(m, "FileError", PyExc_RuntimeError);
  static py::exception<imm::InvalidParameter> invalid(m, "InvalidParameter", PyExc_ValueError);
  // pybind11's translator type takes the pointer by value. This module's functions alone (the
  // lab module has its own, which raises these same classes).
  py::register_local_exception_translator(
      [](std::exception_ptr p) {  // NOLINT(performance-unnecessary-value-param)
        try {
          if (p) std::rethrow_exception(p);
        } catch (const imm::io::FileError& e) {
          file_error(e.what());
        } catch (const imm::InvalidParameter& e) {
          invalid(e.what());
        }
      });

  // The trainer's side (the module immtrain_lab), imported on first use of one of its names, so
  // that a program that only tracks loads the runtime alone; dir(immtrain) lists them where the
  // module is installed.
  static constexpr std::array<std::string_view, 8> kLabNames = {
      "Regime", "load_regime", "regime_from_dict",  "evaluate",
      "rank",   "train",       "import_recordings", "multi_target"};
  m.def("__dir__", [m]() {
    py::list names = py::module_::import("builtins").attr("list")(m.attr("__dict__"));
    const py::object spec = py::module_::import("importlib.util").attr("find_spec")("immtrain_lab");
    if (!spec.is_none()) {
      for (const std::string_view name : kLabNames) names.append(py::str(std::string(name)));
    }
    return names;
  });
  m.def("__getattr__", [](const std::string& name) -> py::object {
    if (std::find(kLabNames.begin(), kLabNames.end(), name) == kLabNames.end()) {
      throw py::attribute_error("module 'immtrain' has no attribute '" + name + "'");
    }
    py::module_ lab;
    try {
      lab = py::module_::import("immtrain_lab");
    } catch (py::error_already_set& error) {
      if (!error.matches(PyExc_ImportError)) throw;
      throw py::import_error("immtrain." + name +
                             " is the trainer's side (the module immtrain_lab), which this "
                             "installation does not have: it was built without the trainer "
                             "(IMM_BUILD_TRAINER=OFF)");
    }
    return lab.attr(name.c_str());
  });

  py::class_<PyTracker>(m, "Tracker",
                        "A model file's filter driven over scan-indexed or timed plots")
      .def("process", &PyTracker::process, py::arg("k"), py::arg("z"),
           "Feeds the plot z = (z1, z2) of scan k; returns what happened")
      .def("process_at", &PyTracker::process_at, py::arg("t"), py::arg("z"),
           "Feeds the plot z taken at time t (s); a model of one sample period takes whole "
           "periods only. A tracker is fed either scans or times")
      .def("run", &PyTracker::run, py::arg("plots"),
           "Runs an (N, 3) array of k, z1, z2; returns numpy arrays of every row")
      .def("state", &PyTracker::state, "The combined mean and covariance")
      .def("mode_probabilities", &PyTracker::mode_probabilities)
      .def_property_readonly("initialized", &PyTracker::initialized)
      .def_property_readonly("state_dimension", &PyTracker::state_dimension)
      .def_property_readonly("state_names", &PyTracker::state_names)
      .def_property_readonly("mode_count", &PyTracker::mode_count)
      .def_property_readonly("mode_names", &PyTracker::mode_names)
      .def_property_readonly("sample_period", &PyTracker::sample_period)
      .def_property_readonly("measurement_kind", &PyTracker::measurement_kind)
      .def_property_readonly("measurement_covariance", &PyTracker::measurement_covariance)
      .def_property_readonly("length_unit", &PyTracker::length_unit)
      .def_property_readonly("kind", &PyTracker::kind)
      .def_property_readonly("regime", &PyTracker::regime);

  py::class_<PyTrackBank>(m, "TrackBank",
                          "Many tracks of one model (any kind load_tracker reads), stepped "
                          "together")
      .def(py::init<const fs::path&, std::size_t>(), py::arg("path"), py::arg("capacity"))
      .def("initialize", &PyTrackBank::initialize, py::arg("track"), py::arg("mean"),
           py::arg("covariance"))
      .def("step", &PyTrackBank::step, py::arg("plots"))
      .def("set_interval", &PyTrackBank::set_interval, py::arg("dt"),
           "The following steps span dt s (a plain IMM without a schedule); False and nothing "
           "changed for a model of one sample period or dt outside 1 µs to 10 h")
      .def("estimate", &PyTrackBank::estimate, py::arg("track"))
      .def("mode_probabilities", &PyTrackBank::mode_probabilities, py::arg("track"))
      .def("candidate_log_likelihoods", &PyTrackBank::candidate_log_likelihoods, py::arg("plots"),
           py::arg("tracks"), py::arg("gate") = INFINITY,
           "The (tracks, plots) matrix of log p(z | track) of candidate plots (M, 2) under tracks "
           "0 … tracks − 1's predictions, -inf where the collapsed squared distance exceeds "
           "`gate` (a χ² quantile, e.g. 9.21 for 99 % with 2-D plots). Changes no track.")
      .def_property_readonly("capacity", &PyTrackBank::capacity)
      .def_property_readonly("state_dimension", &PyTrackBank::state_dimension)
      .def_property_readonly("kind", &PyTrackBank::kind)
      .def_property_readonly("calibrated", &PyTrackBank::calibrated,
                             "True where the bank states its covariances and gate through the "
                             "model file's covariance calibration, as the file's Filter does; "
                             "False: the model's own (a file without a calibration)");

  m.def(
      "load_tracker",
      [](const fs::path& path, std::int64_t max_gap) { return PyTracker(path, max_gap); },
      py::arg("path"), py::arg("max_gap") = imm::kDefaultMaxGap,
      "A model file of any kind the runtime reads, as a Tracker");
  m.def("inspect", &inspect, py::arg("path"),
        "The model's kind, regime, provenance, units and every parameter");
  m.def("verify", &verify, py::arg("path"),
        "Checks a model file (every field and the filter it builds); raises FileError");
  add_filter_binding(m);
  m.def("loadable_kinds", [] {
    std::vector<std::string> kinds;
    for (const auto kind : imm::loadable_model_kinds()) kinds.emplace_back(kind);
    return kinds;
  });
}
