// SPDX-License-Identifier: Apache-2.0
#pragma once
/// A runnable filter for a model file of any kind, built the way the evaluations build it: what the
/// fuzz targets step after a hostile file loads (an invalid value that the reader let through shows
/// up as a non-finite estimate) and what the filter property tests drive with hostile plots.
///
/// Every kind but the input estimator is a TrackFilter; the input estimator is one axis
/// (MlpInputEstimatorFilter) and comes back as `axis`.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "imm/filters/axis_filter.hpp"
#include "imm/filters/fcm_imm.hpp"
#include "imm/filters/fimm.hpp"
#include "imm/filters/ga_fuzzy_imm.hpp"
#include "imm/filters/mlp_input_estimator.hpp"
#include "imm/filters/wimm.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/io/wimm_file.hpp"
#include "imm/tracking/tracker.hpp"

namespace imm::testing {

struct KindFilter {
  std::string kind;
  std::unique_ptr<TrackFilter> filter;  ///< every kind but the input estimator
  TrackOptions options;                 ///< how a Tracker starts it (Cartesian or polar plots)
  std::unique_ptr<MlpInputEstimatorFilter> axis;  ///< the input estimator (one axis)
  /// A plausible first state: position near the plots `first_plot` describes, at rest.
  Eigen::VectorXd initial_mean;
  Eigen::MatrixXd initial_covariance;
};

/// Reads `reader`'s model with its kind's runtime reader and builds the filter. Throws what the
/// readers and the filters' constructors throw (FileError, InvalidParameter).
inline KindFilter make_kind_filter(const io::ModelFileReader& reader) {
  KindFilter made;
  made.kind = reader.provenance().model_kind;
  const auto start = [&](int dimension, double variance) {
    made.initial_mean = Eigen::VectorXd::Zero(dimension);
    made.initial_covariance = Eigen::MatrixXd::Identity(dimension, dimension) * variance;
  };
  if (made.kind == io::kPlainImmKind) {
    const PlainImmSpec spec = io::read_plain_imm(reader);
    made.filter = make_plain_imm_filter(spec);
    made.options = spec.track_options();
  } else if (made.kind == io::kGaFuzzyImmKind) {
    const GaFuzzyImmSpec spec = io::read_ga_fuzzy_imm(reader);
    made.filter = make_ga_fuzzy_imm_filter(spec);
    made.options = spec.track_options();
  } else if (made.kind == io::kWimmKind) {
    const WimmSpec spec = io::read_wimm(reader);
    made.filter = std::make_unique<WimmFilter>(spec);
    made.options = spec.track_options();
  } else if (made.kind == io::kFcmImmKind) {
    const FcmImmSpec spec = io::read_fcm_imm(reader);
    made.filter = make_fcm_imm_filter(spec);
    made.options.sample_period = spec.sample_period;
    made.options.measurement_covariance =
        Eigen::Matrix2d::Identity() * spec.measurement_sigma * spec.measurement_sigma;
  } else if (made.kind == io::kTskSensorKind) {
    auto sensor = std::make_shared<const TskSensorModel>(io::read_tsk_sensor(reader));
    const std::optional<FimmSpec> spec = io::read_fimm_settings(reader);
    if (!spec) throw std::runtime_error("the TSK model stores no FIMM settings (/fimm)");
    made.filter = std::make_unique<FimmFilter>(*spec, std::move(sensor));
    made.options.sample_period = spec->sample_period;
  } else if (made.kind == io::kMlpInputEstimatorKind) {
    MlpInputEstimatorModel model = io::read_mlp_input_estimator(reader);
    const CvKfSettings settings = model.settings;
    made.axis = std::make_unique<MlpInputEstimatorFilter>(std::move(model), settings);
    start(2, settings.measurement_variance);
    return made;
  } else {
    throw io::FileError(reader.file(), "/@model_kind", "unknown kind '" + made.kind + "'");
  }
  // The envelope test the file holds, as load_tracker hands it to the Tracker (whose constructor
  // builds its monitor: the χ² quantiles of the file's significance and dof).
  made.options.envelope = reader.envelope();
  const double variance = made.options.measurement_covariance.diagonal().maxCoeff();
  start(made.filter->state_dimension(), variance > 0.0 ? variance : 1.0);
  return made;
}

/// Whether a TrackFilter's estimate is usable: finite mean and variances (variances ≥ 0), mode
/// probabilities in [0, 1] summing to 1. Empty when it is, else what is wrong.
inline std::string estimate_problem(const TrackFilter& filter) {
  Eigen::VectorXd mean(filter.state_dimension()), variance(filter.state_dimension());
  filter.state(mean, variance);
  if (!mean.allFinite()) return "non-finite mean";
  if (!variance.allFinite() || (variance.array() < 0.0).any()) {
    std::ostringstream text;
    text << "invalid variance: " << variance.transpose() << " (mean " << mean.transpose() << ")";
    return text.str();
  }
  const ModeVector probabilities = filter.mode_probabilities();
  const Eigen::VectorXd mu = probabilities.head(filter.mode_count());
  // A two-axis filter lists the x axis's modes, then the y axis's: one distribution each.
  std::vector<std::pair<int, int>> parts{{0, filter.mode_count()}};
  if (const auto* two = dynamic_cast<const TwoAxisFilter*>(&filter)) {
    const int x_modes = two->axis(0).mode_count();
    parts = {{0, x_modes}, {x_modes, filter.mode_count() - x_modes}};
  }
  for (const auto& [first, count] : parts) {
    const Eigen::VectorXd part = mu.segment(first, count);
    if (!part.allFinite() || (part.array() < 0.0).any() || (part.array() > 1.0).any() ||
        std::abs(part.sum() - 1.0) > 1e-9) {
      std::ostringstream text;
      text << "mode probabilities not a distribution: " << mu.transpose();
      return text.str();
    }
  }
  return {};
}

/// A snapshot of everything a TrackFilter shows, to check that a refused step changed nothing.
struct FilterSnapshot {
  Eigen::VectorXd mean, variance, probabilities;
  explicit FilterSnapshot(const TrackFilter& filter)
      : mean(filter.state_dimension()), variance(filter.state_dimension()) {
    filter.state(mean, variance);
    probabilities = filter.mode_probabilities().head(filter.mode_count());
  }
  /// Bitwise equality (NaN never appears in a valid snapshot).
  [[nodiscard]] bool operator==(const FilterSnapshot& other) const {
    return mean.size() == other.mean.size() && (mean.array() == other.mean.array()).all() &&
           (variance.array() == other.variance.array()).all() &&
           (probabilities.array() == other.probabilities.array()).all();
  }
};

/// A plausible plot of scan k for the filter's measurement space: a target moving a few σ per scan
/// with a small deterministic wobble.
inline Eigen::Vector2d plausible_plot(const TrackOptions& options, std::int64_t k) {
  const double t = static_cast<double>(k);
  const Eigen::Vector2d sigma = options.measurement_covariance.diagonal().cwiseSqrt();
  if (options.measurement_kind == MeasurementKind::kPolar) {
    return {sigma(0) * (200.0 + 2.0 * t + 0.5 * std::sin(t)), 0.3 + sigma(1) * std::sin(0.7 * t)};
  }
  return {sigma(0) * (5.0 * t + 0.5 * std::sin(t)), sigma(1) * (2.0 * t + 0.5 * std::cos(t))};
}

/// A seeded track in the filter's measurement space: plausible_plot plus Gaussian noise of the
/// options' R, a NaN plot at scan 30 and no plots for scans 41–43.
inline std::vector<std::pair<std::int64_t, Eigen::Vector2d>> seeded_plots(
    const TrackOptions& options, std::uint64_t seed, std::int64_t scans) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  const Eigen::Matrix2d L = options.measurement_covariance.llt().matrixL();
  std::vector<std::pair<std::int64_t, Eigen::Vector2d>> plots;
  for (std::int64_t k = 0; k < scans; ++k) {
    if (k >= 41 && k <= 43) continue;
    const double a = normal(rng), b = normal(rng);
    Eigen::Vector2d z = plausible_plot(options, k) + L * Eigen::Vector2d(a, b);
    if (k == 30) z(0) = std::numeric_limits<double>::quiet_NaN();
    plots.emplace_back(k, z);
  }
  return plots;
}

/// Runs `scans` plausible plots through the model's filter (a Tracker for the track filters, the
/// filter itself for the FIMM and the input estimator) and returns the first problem: a non-finite
/// or invalid estimate after an accepted step, or a refused step that changed the estimate. Empty
/// when there is none. What a fuzz target calls after a hostile file has loaded.
inline std::string exercise(KindFilter& made, int scans = 40) {
  if (made.axis) {
    GaussianState<2> start;
    start.covariance *= made.initial_covariance(0, 0);
    made.axis->initialize(start);
    const double sigma = std::sqrt(made.initial_covariance(0, 0));
    for (int k = 0; k < scans; ++k) {
      const GaussianState<2> before = made.axis->estimate();
      const StepStatus status = made.axis->step(sigma * (5.0 * k + 0.5 * std::sin(k)));
      const GaussianState<2>& after = made.axis->estimate();
      if (status == StepStatus::kOk &&
          (!after.all_finite() || !std::isfinite(made.axis->acceleration()))) {
        return "input estimator: non-finite estimate at scan " + std::to_string(k);
      }
      if (status != StepStatus::kOk &&
          (after.mean != before.mean || after.covariance != before.covariance)) {
        return "input estimator: a refused step changed the estimate at scan " + std::to_string(k);
      }
    }
    return {};
  }
  if (made.kind == io::kTskSensorKind) {
    made.filter->initialize(made.initial_mean, made.initial_covariance);
    for (int k = 0; k < scans; ++k) {
      const FilterSnapshot before(*made.filter);
      const double t = 0.1 * k;
      const StepStatus status =
          made.filter->step(Eigen::Vector2d(1.0 + 0.2 * t, 2.0 + 0.1 * std::sin(t)));
      if (status == StepStatus::kOk) {
        if (const std::string problem = estimate_problem(*made.filter); !problem.empty()) {
          return "fimm: " + problem + " at scan " + std::to_string(k);
        }
      } else if (!(FilterSnapshot(*made.filter) == before)) {
        return "fimm: a refused step changed the estimate at scan " + std::to_string(k);
      }
    }
    return {};
  }
  Tracker tracker(std::move(made.filter), made.options);
  for (int k = 0; k < scans; ++k) {
    const bool was_initialized = tracker.initialized();
    std::optional<FilterSnapshot> before;
    if (was_initialized) before.emplace(tracker.filter());
    const TrackStepResult result = tracker.process(k, plausible_plot(made.options, k));
    if (result.event == TrackEvent::kRejected) {
      if (before && !(FilterSnapshot(tracker.filter()) == *before) && result.predicted_scans == 0) {
        return made.kind + ": a rejected plot changed the estimate at scan " + std::to_string(k);
      }
    } else if (tracker.initialized()) {
      if (const std::string problem = estimate_problem(tracker.filter()); !problem.empty()) {
        return made.kind + ": " + problem + " at scan " + std::to_string(k);
      }
    }
  }
  return {};
}

}  // namespace imm::testing
