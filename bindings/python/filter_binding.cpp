// SPDX-License-Identifier: Apache-2.0
// immtrain.Filter: one track's filter of a model file, driven by hand — initialize, then per scan
// step(z), or the cycle in two halves a multi-target tracker needs: predict(), candidate
// questions that change nothing, then update(z) or miss() (imm::TrackFilter).
#include "filter_binding.hpp"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "imm/core/invalid_parameter.hpp"
#include "imm/load.hpp"
#include "imm/tracking/calibrated_filter.hpp"
#include "imm/tracking/tracker.hpp"

namespace py = pybind11;

namespace {

using Plots = py::array_t<double, py::array::c_style | py::array::forcecast>;

class PyFilter {
 public:
  explicit PyFilter(const std::filesystem::path& path) {
    imm::LoadedFilter loaded = imm::load_filter(path);
    filter_ = std::move(loaded.filter);
    options_ = std::move(loaded.options);
    kind_ = loaded.provenance.model_kind;
  }

  void initialize(const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) {
    const int n = filter_->state_dimension();
    const std::string size = std::to_string(n);
    if (mean.size() != n) throw imm::InvalidParameter("mean", "expected " + size + " entries");
    if (covariance.rows() != n || covariance.cols() != n) {
      throw imm::InvalidParameter("covariance", "expected " + size + "×" + size);
    }
    // The filter's own check (imm::require_initial_state) names "initial_state" or
    // "initial_covariance", as a bank's initialize does.
    filter_->initialize(mean, covariance);
    initialized_ = true;
  }

  // Starts the track from two plots (imm::two_point_start, the start imm::Tracker makes); false
  // when they give none (a plot without a finite position, scans that do not increase).
  bool start(std::int64_t first_scan, const Eigen::Vector2d& first, std::int64_t second_scan,
             const Eigen::Vector2d& second) {
    const std::optional<imm::TrackStart> s = imm::two_point_start(
        options_, filter_->state_dimension(), first_scan, first, second_scan, second);
    if (!s) return false;
    filter_->initialize(s->mean, s->covariance);
    initialized_ = true;
    return true;
  }

  // Without dt one cycle spans the filter's interval (its sample period, or the last dt given);
  // with dt, dt seconds after the last cycle (imm::step_over and its siblings).
  std::string step(const Eigen::Vector2d& z, std::optional<double> dt) {
    imm::TrackFilter& f = started();
    return name(dt ? imm::step_over(f, options_.sample_period, *dt, z) : f.step(z));
  }
  std::string predict_only(std::optional<double> dt) {
    imm::TrackFilter& f = started();
    return name(dt ? imm::predict_only_over(f, options_.sample_period, *dt) : f.predict_only());
  }
  std::string predict(std::optional<double> dt) {
    imm::TrackFilter& f = started();
    return name(dt ? imm::predict_over(f, options_.sample_period, *dt) : f.predict());
  }
  std::string update(const Eigen::Vector2d& z) { return name(started().update(z)); }
  std::string miss() { return name(started().miss()); }

  [[nodiscard]] double candidate_log_likelihood(const Eigen::Vector2d& z) const {
    return filter_->candidate_log_likelihood(z);
  }
  [[nodiscard]] double candidate_distance(const Eigen::Vector2d& z) const {
    return filter_->candidate_distance(z);
  }
  // Both questions for plots (M, 2): (log-likelihoods (M,), distances (M,)).
  [[nodiscard]] py::tuple candidates(const Plots& plots) const {
    if (plots.ndim() != 2 || plots.shape(1) != 2) {
      throw imm::InvalidParameter("plots", "expected an (M, 2) array of plots");
    }
    const auto rows = plots.shape(0);
    py::array_t<double> likelihood(rows), distance(rows);
    const auto p = plots.unchecked<2>();
    auto l = likelihood.mutable_unchecked<1>();
    auto d = distance.mutable_unchecked<1>();
    for (py::ssize_t q = 0; q < rows; ++q) {
      const Eigen::Vector2d z(p(q, 0), p(q, 1));
      l(q) = filter_->candidate_log_likelihood(z);
      d(q) = filter_->candidate_distance(z);
    }
    return py::make_tuple(likelihood, distance);
  }
  [[nodiscard]] std::optional<std::pair<Eigen::Vector2d, Eigen::Matrix2d>> predicted_plot() const {
    Eigen::Vector2d z_hat;
    Eigen::Matrix2d S;
    if (!filter_->predicted_plot(z_hat, S)) return std::nullopt;
    return std::make_pair(z_hat, S);
  }

  // Before initialize() or start() there is no state to report (the filter holds placeholders).
  [[nodiscard]] std::pair<Eigen::VectorXd, Eigen::MatrixXd> state() const {
    const imm::TrackFilter& f = started();
    const int n = f.state_dimension();
    Eigen::VectorXd mean(n), variance(n);
    Eigen::MatrixXd covariance(n, n);
    f.state(mean, variance);
    f.covariance(covariance);
    return {mean, covariance};
  }
  [[nodiscard]] Eigen::VectorXd mode_probabilities() const {
    return started().mode_probabilities();
  }
  [[nodiscard]] bool predicts_before_the_plot() const {
    return filter_->predicts_before_the_plot();
  }
  [[nodiscard]] bool has_split_cycle() const { return filter_->has_split_cycle(); }
  [[nodiscard]] bool takes_any_interval() const { return filter_->takes_any_interval(); }
  [[nodiscard]] int state_dimension() const { return filter_->state_dimension(); }
  [[nodiscard]] std::string kind() const { return kind_; }
  [[nodiscard]] double sample_period() const { return options_.sample_period; }
  [[nodiscard]] std::string measurement_kind() const {
    return std::string(imm::to_string(options_.measurement_kind));
  }
  [[nodiscard]] Eigen::Matrix2d measurement_covariance() const {
    return options_.measurement_covariance;
  }
  // The covariance calibration the model file carries and where the track stands in it, or None.
  [[nodiscard]] py::object calibration() const {
    const auto* calibrated = dynamic_cast<const imm::CalibratedFilter*>(filter_.get());
    if (calibrated == nullptr) return py::none();
    const imm::CovarianceCalibration& c = calibrated->calibration();
    py::dict d;
    d["memory"] = c.memory;
    d["nis_cap"] = c.nis_cap;
    d["start_innovation"] = c.start_innovation;
    d["start_state"] = c.start_state;
    d["edges"] = c.edges;
    d["level_innovation"] = c.level_innovation;
    d["level_state"] = c.level_state;
    d["plots_used"] = calibrated->plots_used();
    d["nis_level"] = calibrated->nis_level();
    d["innovation_scale"] = calibrated->innovation_scale();
    d["state_scale"] = calibrated->state_scale();
    return d;
  }

 private:
  static std::string name(imm::StepStatus status) { return std::string(imm::to_string(status)); }
  imm::TrackFilter& started() {
    if (!initialized_) throw std::logic_error("Filter: initialize() it first");
    return *filter_;
  }
  [[nodiscard]] const imm::TrackFilter& started() const {
    if (!initialized_) throw std::logic_error("Filter: initialize() it first");
    return *filter_;
  }

  std::unique_ptr<imm::TrackFilter> filter_;
  imm::TrackOptions options_;
  std::string kind_;
  bool initialized_ = false;
};

}  // namespace

void add_filter_binding(py::module_& m) {
  py::class_<PyFilter>(m, "Filter",
                       "One track's filter of a model file, driven by hand: step(z), or "
                       "predict(), candidate questions, then update(z) or miss()")
      .def(py::init<const std::filesystem::path&>(), py::arg("path"))
      .def("initialize", &PyFilter::initialize, py::arg("mean"), py::arg("covariance"))
      .def("start", &PyFilter::start, py::arg("first_scan"), py::arg("first"),
           py::arg("second_scan"), py::arg("second"))
      .def("step", &PyFilter::step, py::arg("z"), py::arg("dt") = py::none(),
           "One cycle with plot z (dt: s since the last cycle; a model of one sample period "
           "takes whole periods only); returns the status")
      .def("predict_only", &PyFilter::predict_only, py::arg("dt") = py::none(),
           "One cycle without a plot (dt as for step)")
      .def("predict", &PyFilter::predict, py::arg("dt") = py::none(),
           "The first half of a cycle (dt as for step), held until update(z) or miss()")
      .def("candidate_log_likelihood", &PyFilter::candidate_log_likelihood, py::arg("z"))
      .def("candidate_distance", &PyFilter::candidate_distance, py::arg("z"))
      .def("candidates", &PyFilter::candidates, py::arg("plots"))
      .def("predicted_plot", &PyFilter::predicted_plot)
      .def("update", &PyFilter::update, py::arg("z"))
      .def("miss", &PyFilter::miss)
      .def("state", &PyFilter::state)
      .def("mode_probabilities", &PyFilter::mode_probabilities)
      .def_property_readonly("has_split_cycle", &PyFilter::has_split_cycle,
                             "Whether predict(), update() and miss() work (every kind but a "
                             "wIMM that fuses the azimuth)")
      .def_property_readonly("predicts_before_the_plot", &PyFilter::predicts_before_the_plot,
                             "Whether the prediction does not read the plot (else a candidate's "
                             "likelihood is a trial update)")
      .def_property_readonly("takes_any_interval", &PyFilter::takes_any_interval,
                             "Whether dt may be any positive interval (else whole sample periods)")
      .def_property_readonly("state_dimension", &PyFilter::state_dimension)
      .def_property_readonly("kind", &PyFilter::kind)
      .def_property_readonly("sample_period", &PyFilter::sample_period)
      .def_property_readonly("measurement_kind", &PyFilter::measurement_kind)
      .def_property_readonly("measurement_covariance", &PyFilter::measurement_covariance)
      .def_property_readonly("calibration", &PyFilter::calibration,
                             "the model file's covariance calibration (tables) and the track's "
                             "place in it (plots_used, nis_level, innovation_scale, state_scale), "
                             "or None");
}
