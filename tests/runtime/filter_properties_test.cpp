// SPDX-License-Identifier: Apache-2.0
// Properties every filter kind keeps under hostile plots, drilled on every shipped model: whatever
// the measurement (NaN, ±Inf, ±1e300, denormals, zeros, plausible values) and whatever the gap
// pattern, the estimate stays finite with mode probabilities that form a distribution, and a plot
// that is refused changes nothing. Each kind is driven as a tracking application drives it: through
// a Tracker (plain IMM, GA-fuzzy IMM, wIMM, FCM-IMM), through the filter's own step (FIMM, and
// every track filter once started), and axis by axis (the input estimator).

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "imm/core/physical_limits.hpp"
#include "testing/kind_filters.hpp"
#include "testing/shipped_models.hpp"

namespace imm {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

using testing::shipped_models;

/// One coordinate of a hostile plot: mostly the plausible value, otherwise one of the values a
/// broken sensor or a corrupt file sends.
double hostile(double plausible, std::mt19937_64& random) {
  static constexpr double kExtremes[] = {kNan,     kInf, -kInf, 1e300,  -1e300, 1e154,
                                         4.9e-324, 0.0,  -0.0,  1e-300, 1e15};
  std::uniform_int_distribution<int> pick(0, 2 * static_cast<int>(std::size(kExtremes)) - 1);
  const int choice = pick(random);
  return choice < static_cast<int>(std::size(kExtremes)) ? kExtremes[choice] : plausible;
}

/// What every filter must refuse: NaN, ±Inf, or beyond the physical range.
bool usable(const Eigen::Vector2d& z) { return limits::usable_measurement(z); }

/// Every shipped model with its kind, each file read once per process: the three suites' lists
/// are made at test registration, in every process ctest starts for one of their tests.
const std::vector<std::pair<std::filesystem::path, std::string>>& shipped_model_kinds() {
  static const auto kinds = [] {
    std::vector<std::pair<std::filesystem::path, std::string>> read;
    for (const auto& model : shipped_models())
      read.emplace_back(model, io::ModelFileReader(model).provenance().model_kind);
    return read;
  }();
  return kinds;
}

/// The shipped models of the kinds `wanted` accepts.
template <class Wanted>
std::vector<std::filesystem::path> shipped_models_where(Wanted&& wanted) {
  std::vector<std::filesystem::path> models;
  for (const auto& [model, kind] : shipped_model_kinds()) {
    if (wanted(kind)) models.push_back(model);
  }
  return models;
}

bool tracker_kind(const std::string& kind) {
  return kind != io::kMlpInputEstimatorKind && kind != io::kTskSensorKind;
}
bool track_filter_kind(const std::string& kind) { return kind != io::kMlpInputEstimatorKind; }
bool input_estimator_kind(const std::string& kind) { return kind == io::kMlpInputEstimatorKind; }

std::string model_name(const ::testing::TestParamInfo<std::filesystem::path>& param_info) {
  std::string name = param_info.param.stem().string();
  std::replace_if(
      name.begin(), name.end(), [](char c) { return !std::isalnum(c); }, '_');
  return name;
}

class TrackerProperties : public ::testing::TestWithParam<std::filesystem::path> {};
class FilterProperties : public ::testing::TestWithParam<std::filesystem::path> {};
class InputEstimatorProperties : public ::testing::TestWithParam<std::filesystem::path> {};

// Through a Tracker: a plot with NaN/Inf or beyond ±1e9 leaves the track bit for bit unchanged,
// every accepted plot leaves a finite estimate, and gaps of any length never produce a non-finite
// one.
TEST_P(TrackerProperties, NeverHoldsANonFiniteEstimate) {
  const io::ModelFileReader reader(GetParam());
  std::mt19937_64 random(20261123);
  std::uniform_int_distribution<int> gap(1, 12);
  std::bernoulli_distribution bad(0.3), skip(0.15);
  int refused = 0, accepted = 0;
  for (int sequence = 0; sequence < 20; ++sequence) {
    testing::KindFilter made = testing::make_kind_filter(reader);
    const TrackOptions options = made.options;
    Tracker tracker(std::move(made.filter), made.options);
    std::int64_t scan = 0;
    for (int step = 0; step < 80; ++step) {
      scan += skip(random) ? gap(random) : 1;
      Eigen::Vector2d z = testing::plausible_plot(options, scan);
      if (bad(random)) z = Eigen::Vector2d(hostile(z(0), random), hostile(z(1), random));
      std::optional<testing::FilterSnapshot> before;
      if (tracker.initialized()) before.emplace(tracker.filter());
      const TrackStepResult result = tracker.process(scan, z);
      SCOPED_TRACE("sequence " + std::to_string(sequence) + ", scan " + std::to_string(scan));
      if (!usable(z)) {
        ASSERT_EQ(result.event, TrackEvent::kRejected);
        if (before) {
          ASSERT_TRUE(testing::FilterSnapshot(tracker.filter()) == *before);
        }
        ++refused;
      } else if (result.event == TrackEvent::kRejected) {
        ++refused;
      } else {
        ++accepted;
      }
      if (tracker.initialized()) {
        ASSERT_EQ(testing::estimate_problem(tracker.filter()), "");
      }
    }
  }
  EXPECT_GT(accepted, 0);
  EXPECT_GT(refused, 0);
}

// The combined covariance of every kind: symmetric, positive definite, and its diagonal is the
// variance state() reports (the evaluations' NEES reads it).
TEST_P(TrackerProperties, CovarianceIsSymmetricPositiveDefiniteAndMatchesTheVariance) {
  const io::ModelFileReader reader(GetParam());
  testing::KindFilter made = testing::make_kind_filter(reader);
  const TrackOptions options = made.options;
  Tracker tracker(std::move(made.filter), made.options);
  const int n = tracker.state_dimension();
  Eigen::VectorXd mean(n), variance(n);
  Eigen::MatrixXd covariance(n, n);
  EXPECT_THROW(tracker.covariance(covariance), std::logic_error);  // no track yet
  int checked = 0;
  for (std::int64_t scan = 0; scan < 30; ++scan) {
    (void)tracker.process(scan, testing::plausible_plot(options, scan));
    if (!tracker.initialized()) continue;
    tracker.state(mean, variance);
    tracker.covariance(covariance);
    ASSERT_EQ(covariance.diagonal(), variance) << "scan " << scan;
    ASSERT_LE((covariance - covariance.transpose()).cwiseAbs().maxCoeff(),
              1e-12 * covariance.cwiseAbs().maxCoeff())
        << "scan " << scan;
    ASSERT_EQ(Eigen::LLT<Eigen::MatrixXd>(covariance).info(), Eigen::Success) << "scan " << scan;
    ++checked;
  }
  EXPECT_GT(checked, 20);
}

// The innovation behind the evaluations' NIS: after every update a finite ν with a symmetric
// positive definite S, and a finite predictive log-likelihood; before the track's first update none
// (a plot the tracker refuses never reaches the filter, whose last innovation then stands).
TEST_P(TrackerProperties, ReportsAnInnovationAfterEveryUpdateAndNoneOtherwise) {
  const io::ModelFileReader reader(GetParam());
  testing::KindFilter made = testing::make_kind_filter(reader);
  const TrackOptions options = made.options;
  Tracker tracker(std::move(made.filter), made.options);
  Eigen::Vector2d nu;
  Eigen::Matrix2d S;
  int updates = 0;
  for (std::int64_t scan = 0; scan < 30; ++scan) {
    const bool gap = scan == 20;
    const TrackStepResult result =
        gap ? tracker.process(scan, Eigen::Vector2d(kNan, kNan))
            : tracker.process(scan, testing::plausible_plot(options, scan));
    SCOPED_TRACE("scan " + std::to_string(scan));
    if (result.event == TrackEvent::kRejected) continue;  // the filter was not called
    if (result.event != TrackEvent::kUpdated) {
      ASSERT_FALSE(tracker.filter().innovation(nu, S)) << to_string(result.event);
      ASSERT_TRUE(std::isnan(tracker.filter().log_predictive_likelihood()));
      continue;
    }
    ASSERT_TRUE(tracker.filter().innovation(nu, S));
    ASSERT_TRUE(std::isfinite(tracker.filter().log_predictive_likelihood()));
    ASSERT_TRUE(nu.allFinite() && S.allFinite());
    ASSERT_LE(std::abs(S(0, 1) - S(1, 0)), 1e-12 * S.cwiseAbs().maxCoeff());
    ASSERT_EQ(Eigen::LLT<Eigen::Matrix2d>(S).info(), Eigen::Success);
    ++updates;
  }
  EXPECT_GT(updates, 20);
}

// The filter's own step, started from a plausible state: a refused step changes nothing, an
// accepted one leaves a finite estimate; predict_only through long gaps stays finite.
TEST_P(FilterProperties, StepRefusesOrStaysFinite) {
  const io::ModelFileReader reader(GetParam());
  std::mt19937_64 random(77);
  std::bernoulli_distribution bad(0.4), predict(0.1);
  for (int sequence = 0; sequence < 20; ++sequence) {
    testing::KindFilter made = testing::make_kind_filter(reader);
    TrackFilter& filter = *made.filter;
    filter.initialize(made.initial_mean, made.initial_covariance);
    for (int k = 0; k < 60; ++k) {
      SCOPED_TRACE("sequence " + std::to_string(sequence) + ", step " + std::to_string(k));
      const testing::FilterSnapshot before(filter);
      if (predict(random)) {
        const StepStatus status = filter.predict_only();
        if (status != StepStatus::kOk) {
          ASSERT_TRUE(testing::FilterSnapshot(filter) == before);
        }
        ASSERT_EQ(testing::estimate_problem(filter), "");
        continue;
      }
      Eigen::Vector2d z = made.kind == io::kTskSensorKind
                              ? Eigen::Vector2d(1.0 + 0.02 * k, 2.0)
                              : testing::plausible_plot(made.options, k);
      if (bad(random)) z = Eigen::Vector2d(hostile(z(0), random), hostile(z(1), random));
      const StepStatus status = filter.step(z);
      if (!usable(z)) {
        ASSERT_EQ(status, StepStatus::kInvalidMeasurement);
      }
      if (status != StepStatus::kOk) {
        ASSERT_TRUE(testing::FilterSnapshot(filter) == before);
      }
      ASSERT_EQ(testing::estimate_problem(filter), "");
    }
  }
}

// The input estimator, one axis: the same two properties.
TEST_P(InputEstimatorProperties, StepRefusesOrStaysFinite) {
  const io::ModelFileReader reader(GetParam());
  std::mt19937_64 random(5);
  std::bernoulli_distribution bad(0.4);
  testing::KindFilter made = testing::make_kind_filter(reader);
  const double sigma = std::sqrt(made.initial_covariance(0, 0));
  for (int sequence = 0; sequence < 20; ++sequence) {
    GaussianState<2> start;
    start.covariance *= sigma * sigma;
    made.axis->initialize(start);
    for (int k = 0; k < 60; ++k) {
      SCOPED_TRACE("sequence " + std::to_string(sequence) + ", step " + std::to_string(k));
      const GaussianState<2> before = made.axis->estimate();
      double z = sigma * 5.0 * k;
      if (bad(random)) z = hostile(z, random);
      const StepStatus status = made.axis->step(z);
      const GaussianState<2>& after = made.axis->estimate();
      if (!limits::usable_measurement(z)) {
        ASSERT_EQ(status, StepStatus::kInvalidMeasurement);
      }
      if (status != StepStatus::kOk) {
        ASSERT_TRUE(after.mean == before.mean && after.covariance == before.covariance);
      }
      ASSERT_TRUE(after.all_finite());
      ASSERT_TRUE(std::isfinite(made.axis->acceleration()));
    }
  }
}

INSTANTIATE_TEST_SUITE_P(ShippedModels, TrackerProperties,
                         ::testing::ValuesIn(shipped_models_where(tracker_kind)), model_name);
INSTANTIATE_TEST_SUITE_P(ShippedModels, FilterProperties,
                         ::testing::ValuesIn(shipped_models_where(track_filter_kind)), model_name);
INSTANTIATE_TEST_SUITE_P(ShippedModels, InputEstimatorProperties,
                         ::testing::ValuesIn(shipped_models_where(input_estimator_kind)),
                         model_name);

}  // namespace
}  // namespace imm
