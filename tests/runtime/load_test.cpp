// SPDX-License-Identifier: Apache-2.0
// imm::load_filter / imm::load_tracker (imm/load.hpp): every shipped model through the one entry
// point equals its kind-specific recipe step for step, to the bit; the input estimator tracks in
// two dimensions as two independent axis filters; the FIMM settings stored with a TSK sensor model
// round-trip and are refused, naming the field, when invalid; and what load_filter refuses.

#include "imm/load.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <random>

#include "imm/core/invalid_parameter.hpp"
#include "imm/io/file_error.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/tracking/calibrated_filter.hpp"
#include "testing/hdf5_edit.hpp"
#include "testing/kind_filters.hpp"
#include "testing/model_files.hpp"
#include "testing/shipped_models.hpp"
#include "testing/temp_dir.hpp"

namespace imm {
namespace {

constexpr int kScans = 80;

// `filter` with the file's covariance calibration around it, as load_filter applies it
// (calibrated_filter.hpp; the calibration itself is tested in calibrated_filter_test.cpp).
std::unique_ptr<TrackFilter> as_loaded(std::unique_ptr<TrackFilter> filter,
                                       const io::ModelFileReader& reader) {
  if (auto calibration = read_calibration(reader)) {
    return std::make_unique<CalibratedFilter>(std::move(filter), std::move(calibration));
  }
  return filter;
}

// The factor of P the tracker's filter states its covariance with (1 without a calibration).
double state_scale(const Tracker& tracker) {
  const auto* calibrated = dynamic_cast<const CalibratedFilter*>(&tracker.filter());
  return calibrated != nullptr ? calibrated->state_scale() : 1.0;
}

struct Estimate {
  Eigen::VectorXd mean, variance;
  explicit Estimate(const Tracker& tracker)
      : mean(tracker.state_dimension()), variance(tracker.state_dimension()) {
    tracker.state(mean, variance);
  }
};

void expect_same_options(const TrackOptions& a, const TrackOptions& b, const std::string& name) {
  EXPECT_EQ(a.sample_period, b.sample_period) << name;
  EXPECT_EQ(a.measurement_kind, b.measurement_kind) << name;
  EXPECT_EQ(a.measurement_covariance, b.measurement_covariance) << name;
  EXPECT_EQ(a.initialization.method, b.initialization.method) << name;
  EXPECT_EQ(a.initialization.acceleration_variance, b.initialization.acceleration_variance) << name;
  EXPECT_EQ(a.max_gap, b.max_gap) << name;
}

// The shipped plain, GA-fuzzy, FCM and weighted IMMs: load_tracker against the kind's own reader,
// spec, filter factory and track options (tests/testing/kind_filters.hpp).
TEST(LoadTracker, EveryShippedTrackFilterEqualsItsKindSpecificRecipe) {
  int compared = 0;
  for (const auto& path : testing::shipped_models()) {
    const io::ModelFileReader reader(path);
    testing::KindFilter made = testing::make_kind_filter(reader);
    if (made.axis || made.kind == io::kTskSensorKind) continue;  // their own tests below
    SCOPED_TRACE(path.string());
    LoadedFilter loaded = load_filter(path);
    EXPECT_EQ(loaded.provenance.model_kind, made.kind);
    expect_same_options(loaded.options, made.options, path.string());
    ASSERT_EQ(loaded.filter->mode_count(), made.filter->mode_count());
    Tracker expected(as_loaded(std::move(made.filter), reader), made.options);
    Tracker tracker = load_tracker(path);
    for (const auto& [k, z] : testing::seeded_plots(made.options, 7, kScans)) {
      const TrackStepResult a = tracker.process(k, z), b = expected.process(k, z);
      ASSERT_EQ(a.event, b.event) << "scan " << k;
      if (!tracker.initialized()) continue;
      const Estimate x(tracker), y(expected);
      ASSERT_TRUE((x.mean.array() == y.mean.array()).all()) << "scan " << k;
      ASSERT_TRUE((x.variance.array() == y.variance.array()).all()) << "scan " << k;
      ASSERT_TRUE(
          (tracker.mode_probabilities().array() == expected.mode_probabilities().array()).all())
          << "scan " << k;
    }
    ++compared;
  }
  EXPECT_GE(compared, 4);
}

// The input estimator: x and y each an MlpInputEstimatorFilter of the file's model, started by hand
// as a two-point start (p = z₂, v = (z₂ − z₁)/T, cov [[R, R/T], [R/T, 2R/T²]]).
// A maker reads the file once and builds filters that are independent of each other (one track
// does not move another) and equal, step for step, to load_tracker's.
TEST(LoadFilterMaker, EveryShippedKindMakesIndependentFiltersEqualToLoadTrackers) {
  int compared = 0;
  for (const auto& path : testing::shipped_models()) {
    SCOPED_TRACE(path.string());
    const FilterMaker maker = load_filter_maker(path);
    Tracker first(maker.make(), maker.options), second(maker.make(), maker.options);
    Tracker expected = load_tracker(path);
    const auto plots = testing::seeded_plots(maker.options, 11, kScans);
    for (const auto& [k, z] : plots) {
      const TrackStepResult a = first.process(k, z), b = expected.process(k, z);
      ASSERT_EQ(a.event, b.event) << "scan " << k;
      if (!first.initialized()) continue;
      const Estimate x(first), y(expected);
      ASSERT_TRUE((x.mean.array() == y.mean.array()).all()) << "scan " << k;
      ASSERT_TRUE((x.variance.array() == y.variance.array()).all()) << "scan " << k;
    }
    EXPECT_FALSE(second.initialized());  // untouched by the first track
    for (const auto& [k, z] : plots) (void)second.process(k, z);
    const Estimate x(first), y(second);
    EXPECT_TRUE((x.mean.array() == y.mean.array()).all());
    ++compared;
  }
  EXPECT_GE(compared, 6);
  EXPECT_THROW((void)load_filter_maker("no/such/model.h5"), io::FileError);
}

// Every shipped model's filter refuses a start of the wrong shape, not finite, not symmetric or
// with a negative variance, naming the field, and is left as the valid start before made it.
TEST(LoadFilter, EveryShippedKindRefusesAnInvalidStartByName) {
  int drilled = 0;
  for (const auto& path : testing::shipped_models()) {
    SCOPED_TRACE(path.string());
    const std::unique_ptr<TrackFilter> filter = load_filter(path).filter;
    const int n = filter->state_dimension();
    const auto field_of = [&](const Eigen::VectorXd& mean, const Eigen::MatrixXd& covariance) {
      try {
        filter->initialize(mean, covariance);
      } catch (const InvalidParameter& error) {
        return error.field();
      }
      return std::string();
    };
    const Eigen::VectorXd mean = Eigen::VectorXd::LinSpaced(n, 100.0, 200.0);
    const Eigen::MatrixXd covariance = 4.0 * Eigen::MatrixXd::Identity(n, n);
    ASSERT_EQ(field_of(mean, covariance), "");
    Eigen::VectorXd before(n), after(n);
    Eigen::VectorXd variance(n);
    filter->state(before, variance);
    EXPECT_EQ(field_of(Eigen::VectorXd::Zero(n + 1), covariance), "initial_state");
    EXPECT_EQ(field_of(Eigen::VectorXd::Zero(n - 1), covariance), "initial_state");
    Eigen::VectorXd nan_mean = mean;
    nan_mean(1) = std::numeric_limits<double>::quiet_NaN();
    EXPECT_EQ(field_of(nan_mean, covariance), "initial_state");
    EXPECT_EQ(field_of(mean, Eigen::MatrixXd::Identity(n + 1, n + 1)), "initial_covariance");
    EXPECT_EQ(field_of(mean, Eigen::MatrixXd::Identity(n, n - 1)), "initial_covariance");
    Eigen::MatrixXd skew = covariance;
    skew(0, 1) = 0.5;
    EXPECT_EQ(field_of(mean, skew), "initial_covariance");
    Eigen::MatrixXd negative = covariance;
    negative(n - 1, n - 1) = -1.0;
    EXPECT_EQ(field_of(mean, negative), "initial_covariance");
    Eigen::MatrixXd infinite = covariance;
    infinite(0, 0) = std::numeric_limits<double>::infinity();
    EXPECT_EQ(field_of(mean, infinite), "initial_covariance");
    filter->state(after, variance);
    EXPECT_TRUE((before.array() == after.array()).all());
    ++drilled;
  }
  EXPECT_GE(drilled, 6);
}

TEST(LoadTracker, InputEstimatorTracksAsTwoIndependentAxisFilters) {
  int compared = 0;
  for (const auto& path : testing::shipped_models()) {
    const io::ModelFileReader reader(path);
    if (reader.provenance().model_kind != io::kMlpInputEstimatorKind) continue;
    SCOPED_TRACE(path.string());
    const MlpInputEstimatorModel model = io::read_mlp_input_estimator(reader);
    Tracker tracker = load_tracker(path);
    EXPECT_EQ(tracker.mode_count(), 2);
    EXPECT_EQ(tracker.filter().mode_name(0), "x.input estimation");
    const TrackOptions options = model.track_options();
    const double T = model.settings.sample_period, R = model.settings.measurement_variance;
    EXPECT_EQ(options.measurement_covariance, R * Eigen::Matrix2d::Identity());
    std::vector<MlpInputEstimatorFilter> axes(2, MlpInputEstimatorFilter(model, model.settings));
    const auto plots = testing::seeded_plots(options, 11, kScans);
    for (std::size_t i = 0; i < plots.size(); ++i) {
      const auto& [k, z] = plots[i];
      const TrackStepResult result = tracker.process(k, z);
      if (i == 0) continue;
      if (i == 1) {
        ASSERT_EQ(result.event, TrackEvent::kInitialized);
        for (int a = 0; a < 2; ++a) {
          GaussianState<2> start;
          start.mean << z(a), (z(a) - plots[0].second(a)) / T;
          start.covariance << R, R / T, R / T, 2.0 * R / (T * T);
          axes[static_cast<std::size_t>(a)].initialize(start);
        }
      } else if (!z.allFinite()) {
        ASSERT_EQ(result.event, TrackEvent::kRejected);
        continue;
      } else {
        ASSERT_EQ(result.event, TrackEvent::kUpdated) << "scan " << k;
        for (std::int64_t skipped = 0; skipped < result.predicted_scans; ++skipped) {
          for (auto& axis : axes) axis.predict_only();
        }
        for (int a = 0; a < 2; ++a) {
          ASSERT_EQ(axes[static_cast<std::size_t>(a)].step(z(a)), StepStatus::kOk);
        }
      }
      const Estimate x(tracker);
      for (int a = 0; a < 2; ++a) {
        const GaussianState<2>& e = axes[static_cast<std::size_t>(a)].estimate();
        ASSERT_EQ(x.mean(2 * a), e.mean(0)) << "scan " << k;
        ASSERT_EQ(x.mean(2 * a + 1), e.mean(1)) << "scan " << k;
        ASSERT_EQ(x.variance(2 * a), e.covariance(0, 0) * state_scale(tracker)) << "scan " << k;
        ASSERT_EQ(x.variance(2 * a + 1), e.covariance(1, 1) * state_scale(tracker)) << "scan " << k;
      }
    }
    ++compared;
  }
  EXPECT_GE(compared, 1);
}

// Without a plot both KFs predict with the held û: p ← p + T v + T²/2 û, v ← v + T û,
// P ← F P Fᵀ + q [[T⁴/4, T³/2], [T³/2, T²]], computed here by hand.
TEST(MlpInputEstimatorFilter, PredictOnlyHoldsTheLastInputEstimate) {
  for (const auto& path : testing::shipped_models()) {
    const io::ModelFileReader reader(path);
    if (reader.provenance().model_kind != io::kMlpInputEstimatorKind) continue;
    const MlpInputEstimatorModel model = io::read_mlp_input_estimator(reader);
    // The primary KF's q: the features' q plus the input's error variance (0 for the seed's).
    const double T = model.settings.sample_period;
    const double q = model.settings.process_noise + model.input_variance;
    const double sigma = std::sqrt(model.settings.measurement_variance);
    MlpInputEstimatorFilter filter(model, model.settings);
    GaussianState<2> start;
    start.covariance *= model.settings.measurement_variance;
    filter.initialize(start);
    for (int k = 1; k <= 40; ++k) {  // a hard turn: û becomes non-zero
      ASSERT_EQ(filter.step(sigma * (0.02 * k * k * k)), StepStatus::kOk);
    }
    const double u = filter.acceleration();
    EXPECT_NE(u, 0.0) << path;  // the case worth checking: a held, non-zero input
    const GaussianState<2> before = filter.estimate();
    filter.predict_only();
    const GaussianState<2>& after = filter.estimate();
    const double p = before.mean(0), v = before.mean(1);
    EXPECT_DOUBLE_EQ(after.mean(0), p + T * v + 0.5 * T * T * u) << path;
    EXPECT_DOUBLE_EQ(after.mean(1), v + T * u) << path;
    const Eigen::Matrix2d& P = before.covariance;
    const double p00 = P(0, 0) + 2 * T * P(0, 1) + T * T * P(1, 1) + q * std::pow(T, 4) / 4;
    const double p01 = P(0, 1) + T * P(1, 1) + q * std::pow(T, 3) / 2;
    const double p11 = P(1, 1) + q * T * T;
    EXPECT_NEAR(after.covariance(0, 0), p00, 1e-12 * p00) << path;
    EXPECT_NEAR(after.covariance(0, 1), p01, 1e-12 * std::abs(p01) + 1e-300) << path;
    EXPECT_NEAR(after.covariance(1, 1), p11, 1e-12 * p11) << path;
    EXPECT_EQ(filter.acceleration(), u);
  }
}

// The FIMM of a TSK sensor file: its settings come from the file, and the track starts as
// imm-eval fimm starts it (two-point with R, the acceleration variance from the settings). Every
// shipped sensor model carries its settings (a file without them is refused naming /fimm: below).
TEST(LoadTracker, TskSensorModelRunsTheFimmWithTheSettingsItCarries) {
  int compared = 0;
  for (const auto& path : testing::shipped_models()) {
    const io::ModelFileReader reader(path);
    if (reader.provenance().model_kind != io::kTskSensorKind) continue;
    SCOPED_TRACE(path.string());
    const std::optional<FimmSpec> spec = io::read_fimm_settings(reader);
    ASSERT_TRUE(spec) << "a shipped sensor model without its FIMM settings";
    const auto sensor = std::make_shared<const TskSensorModel>(io::read_tsk_sensor(reader));
    const auto expected = as_loaded(std::make_unique<FimmFilter>(*spec, sensor), reader);
    Tracker tracker = load_tracker(path);
    const TrackOptions options = spec->track_options();
    const double T = spec->sample_period;
    const Eigen::Matrix2d& R = spec->measurement_covariance;
    std::vector<std::pair<std::int64_t, Eigen::Vector2d>> plots;
    for (std::int64_t k = 0; k < kScans; ++k) {  // a lane change seen by the sensor
      const double t = T * static_cast<double>(k);
      plots.emplace_back(k, Eigen::Vector2d(1.5 + 0.5 * std::tanh(t - 4.0), 20.0 + 25.0 * t));
    }
    for (std::size_t i = 0; i < plots.size(); ++i) {
      const auto& [k, z] = plots[i];
      const TrackStepResult result = tracker.process(k, z);
      if (i == 0) continue;
      if (i == 1) {
        Eigen::VectorXd mean = Eigen::VectorXd::Zero(6);
        Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(6, 6);
        for (int a = 0; a < 2; ++a) {
          const double r = R(a, a);
          mean(3 * a) = z(a);
          mean(3 * a + 1) = (z(a) - plots[0].second(a)) / T;
          covariance.block<3, 3>(3 * a, 3 * a) << r, r / T, 0.0, r / T, 2.0 * r / (T * T), 0.0, 0.0,
              0.0, spec->acceleration_variance;
        }
        expected->initialize(mean, covariance);
      } else {
        ASSERT_EQ(result.event, TrackEvent::kUpdated);
        ASSERT_EQ(expected->step(z), StepStatus::kOk);
      }
      Eigen::VectorXd mean(6), variance(6);
      expected->state(mean, variance);
      const Estimate x(tracker);
      ASSERT_TRUE((x.mean.array() == mean.array()).all()) << "scan " << k;
      ASSERT_TRUE((x.variance.array() == variance.array()).all()) << "scan " << k;
    }
    EXPECT_EQ(options.measurement_kind, MeasurementKind::kCartesian);
    ++compared;
  }
  EXPECT_GE(compared, 2);  // tsk_range_sensor and tsk_range_sensor_hard
}

std::shared_ptr<const TskSensorModel> identity_sensor() {
  std::array<TskOutput, 2> outputs;
  TskRule x, y;
  x.center = y.center = Eigen::Vector2d::Zero();
  x.width = y.width = Eigen::Vector2d::Constant(1e3);
  x.consequent << 0.0, 1.0, 0.0;
  y.consequent << 0.0, 0.0, 1.0;
  outputs[0].rules = {x};
  outputs[1].rules = {y};
  return std::make_shared<const TskSensorModel>(
      outputs, TNorm::kMin, Eigen::Vector2d::Constant(-1e6), Eigen::Vector2d::Constant(1e6));
}

std::filesystem::path write_tsk_file(const std::filesystem::path& path, const FimmSpec* fimm) {
  testing::write_model(
      path, io::kTskSensorKind,
      [&](io::ModelFileWriter& writer) {
        io::write_tsk_sensor(writer, *identity_sensor());
        if (fimm != nullptr) io::write_fimm_settings(writer, *fimm);
      },
      "test");
  return path;
}

TEST(FimmSettings, RoundTripThroughTheSensorFile) {
  testing::TempDir dir;
  FimmSpec spec;
  spec.sample_period = 0.25;
  spec.cruise_sigma = 2e-3;
  spec.lane_change_ratio = 7.0;
  spec.noise_scale = 30.0;
  spec.iterations = 3;
  spec.acceleration_variance = 9.0;
  spec.transition << 0.9, 0.1, 0.2, 0.8;
  spec.initial_probabilities << 0.7, 0.3;
  spec.measurement_covariance << 0.04, 0.01, 0.01, 0.09;
  const auto path = write_tsk_file(dir.path() / "sensor.h5", &spec);
  const std::optional<FimmSpec> back = io::read_fimm_settings(io::ModelFileReader(path));
  ASSERT_TRUE(back);
  EXPECT_EQ(back->sample_period, spec.sample_period);
  EXPECT_EQ(back->cruise_sigma, spec.cruise_sigma);
  EXPECT_EQ(back->lane_change_ratio, spec.lane_change_ratio);
  EXPECT_EQ(back->noise_scale, spec.noise_scale);
  EXPECT_EQ(back->iterations, spec.iterations);
  EXPECT_EQ(back->acceleration_variance, spec.acceleration_variance);
  EXPECT_EQ(back->transition, spec.transition);
  EXPECT_EQ(back->initial_probabilities, spec.initial_probabilities);
  EXPECT_EQ(back->measurement_covariance, spec.measurement_covariance);
  const LoadedFilter loaded = load_filter(path);
  EXPECT_EQ(loaded.options.sample_period, 0.25);
  EXPECT_EQ(loaded.options.measurement_covariance, spec.measurement_covariance);
  EXPECT_EQ(loaded.options.initialization.acceleration_variance, 9.0);
  EXPECT_EQ(loaded.filter->state_dimension(), 6);
}

std::string load_error(const std::filesystem::path& path) {
  try {
    (void)load_filter(path);
  } catch (const io::FileError& error) {
    return error.what();
  }
  return "(loaded)";
}

TEST(FimmSettings, InvalidOrMissingSettingsAreRefusedNamingTheField) {
  testing::TempDir dir;
  FimmSpec spec;
  spec.sample_period = 0.1;
  const auto path = write_tsk_file(dir.path() / "sensor.h5", &spec);
  testing::edit_and_reseal(path, [](hid_t file) {
    testing::replace_dataset(file, "/fimm/transition", {2, 2}, {0.5, 0.4, 0.03, 0.97});
  });
  EXPECT_NE(load_error(path).find("/fimm/transition"), std::string::npos) << load_error(path);

  const auto negative = write_tsk_file(dir.path() / "negative.h5", &spec);
  testing::edit_and_reseal(negative, [](hid_t file) {
    const double value = -1.0;
    testing::set_attribute(file, "/fimm", "noise_scale", H5T_NATIVE_DOUBLE, &value);
  });
  EXPECT_NE(load_error(negative).find("/fimm@noise_scale"), std::string::npos)
      << load_error(negative);

  const auto old = write_tsk_file(dir.path() / "old.h5", nullptr);
  EXPECT_FALSE(io::read_fimm_settings(io::ModelFileReader(old)));
  EXPECT_NE(load_error(old).find("'/fimm': missing"), std::string::npos) << load_error(old);
}

TEST(LoadFilter, RefusesAMissingFileAndAnUnknownKind) {
  testing::TempDir dir;
  const std::string missing = load_error(dir.path() / "nothing.h5");
  EXPECT_NE(missing.find("no such model file"), std::string::npos) << missing;

  io::Provenance provenance;
  provenance.model_kind = "kalman_oracle";
  io::ModelFileWriter writer(dir.path() / "oracle.h5", provenance);
  writer.commit();
  const std::string unknown = load_error(dir.path() / "oracle.h5");
  EXPECT_NE(unknown.find("@model_kind"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("unknown model kind 'kalman_oracle'"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("plain_imm"), std::string::npos) << unknown;  // lists what it reads
}

}  // namespace
}  // namespace imm
