// SPDX-License-Identifier: Apache-2.0
// The split cycle behind the TrackFilter interface (load_filter's filter of any kind): a filter
// that predicts before its plot gives, through predict(), candidate questions and update() or
// miss(), the numbers of step() and predict_only() to the bit on every shipped model of its kind;
// every other filter says it does not split its cycle and refuses predict() by std::logic_error,
// its candidate questions NaN.

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "imm/load.hpp"
#include "testing/kind_filters.hpp"
#include "testing/shipped_models.hpp"

namespace imm {
namespace {

struct Snapshot {
  Eigen::VectorXd mean, variance;
  Eigen::MatrixXd covariance;
  explicit Snapshot(const TrackFilter& f)
      : mean(f.state_dimension()),
        variance(f.state_dimension()),
        covariance(f.state_dimension(), f.state_dimension()) {
    f.state(mean, variance);
    f.covariance(covariance);
  }
  bool operator==(const Snapshot& o) const {
    return std::memcmp(mean.data(), o.mean.data(), sizeof(double) * mean.size()) == 0 &&
           std::memcmp(covariance.data(), o.covariance.data(),
                       sizeof(double) * covariance.size()) == 0;
  }
};

// A start at the first plot's position with a broad covariance.
void start_both(TrackFilter& a, TrackFilter& b, const TrackOptions& options,
                const Eigen::Vector2d& first) {
  const int n = a.state_dimension();
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(n);
  const int y = n >= 6 ? 3 : 2;
  if (options.measurement_kind == MeasurementKind::kPolar) {
    mean(0) = first(0) * std::cos(first(1));
    mean(y) = first(0) * std::sin(first(1));
  } else {
    mean(0) = first(0);
    mean(y) = first(1);
  }
  const double r = options.measurement_kind == MeasurementKind::kPolar
                       ? first(0) * first(0) * options.measurement_covariance(1, 1)
                       : options.measurement_covariance(0, 0);
  Eigen::MatrixXd P = Eigen::MatrixXd::Identity(n, n) * 100.0 * r;
  if (n % 2 == 1) P(n - 1, n - 1) = 1e-4;  // the turn rate
  a.initialize(mean, P);
  b.initialize(mean, P);
}

TEST(SplitTrackFilter, EqualsStepToTheBitForEveryKindThatSplitsAndIsRefusedByTheOthers) {
  int split = 0, refused = 0;
  for (const auto& path : testing::shipped_models()) {
    SCOPED_TRACE(path.string());
    LoadedFilter whole = load_filter(path), halves = load_filter(path);
    const auto plots = testing::seeded_plots(whole.options, 5, 80);
    start_both(*whole.filter, *halves.filter, whole.options, plots.front().second);
    if (!halves.filter->predicts_before_the_plot()) {
      EXPECT_THROW((void)halves.filter->predict(), std::logic_error);
      EXPECT_THROW((void)halves.filter->miss(), std::logic_error);
      EXPECT_TRUE(std::isnan(halves.filter->candidate_log_likelihood(plots[1].second)));
      EXPECT_TRUE(std::isnan(halves.filter->candidate_distance(plots[1].second)));
      ++refused;
      continue;
    }
    std::int64_t last = plots.front().first;
    for (std::size_t i = 1; i < plots.size(); ++i) {
      const auto& [k, z] = plots[i];
      // Scans without a plot: missed (the split) or predicted through (the whole cycle).
      for (; last + 1 < k; ++last) {
        ASSERT_EQ(halves.filter->predict(), StepStatus::kOk);
        ASSERT_EQ(halves.filter->miss(), whole.filter->predict_only());
      }
      last = k;
      ASSERT_EQ(halves.filter->predict(), StepStatus::kOk) << k;
      const Snapshot before(*halves.filter);
      const double likelihood = halves.filter->candidate_log_likelihood(z);
      (void)halves.filter->candidate_distance(z);
      Eigen::Vector2d z_hat;
      Eigen::Matrix2d S;
      ASSERT_TRUE(halves.filter->predicted_plot(z_hat, S));
      EXPECT_TRUE(Snapshot(*halves.filter) == before) << "a candidate question moved the track";
      const StepStatus status = whole.filter->step(z);
      ASSERT_EQ(halves.filter->update(z), status) << k;
      if (status != StepStatus::kOk) {
        // A refused plot (the NaN one): the track waits for another plot or a miss.
        ASSERT_EQ(halves.filter->miss(), whole.filter->predict_only());
      } else {
        EXPECT_NEAR(likelihood, halves.filter->log_predictive_likelihood(),
                    1e-9 * std::max(1.0, std::abs(likelihood)));
      }
      ASSERT_TRUE(Snapshot(*whole.filter) == Snapshot(*halves.filter)) << "scan " << k;
      ASSERT_EQ(whole.filter->mode_probabilities(), halves.filter->mode_probabilities());
    }
    ++split;
  }
  EXPECT_GE(split, 5);    // the plain IMMs without a schedule
  EXPECT_GE(refused, 6);  // every learned kind, the scheduled IMMs
}

}  // namespace
}  // namespace imm
