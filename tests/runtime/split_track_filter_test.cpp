// SPDX-License-Identifier: Apache-2.0
// The split cycle behind the TrackFilter interface (load_filter's filter of any kind): a filter
// that splits its cycle gives, through predict(), candidate questions (of other plots first) and
// update() or miss(), the numbers of step() and predict_only() to the bit on every shipped model
// of its kind, learned kinds included (their candidates are trial updates); a filter that does
// not split (a wIMM that fuses the azimuth) says so and refuses predict() by std::logic_error, its
// candidate questions NaN.

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>

#include "imm/load.hpp"
#include "testing/filter_snapshot.hpp"
#include "testing/kind_filters.hpp"
#include "testing/shipped_models.hpp"

namespace imm {
namespace {

using testing::Snapshot;
using testing::start_both;

TEST(SplitTrackFilter, EqualsStepToTheBitForEveryKindThatSplitsAndIsRefusedByTheOthers) {
  int split = 0, refused = 0;
  for (const auto& path : testing::shipped_models()) {
    SCOPED_TRACE(path.string());
    LoadedFilter whole = load_filter(path), halves = load_filter(path);
    const auto plots = testing::seeded_plots(whole.options, 5, 80);
    start_both(*whole.filter, *halves.filter, whole.options, plots.front().second);
    if (!halves.filter->has_split_cycle()) {
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
      // Another candidate first: a trial update must leave nothing behind.
      (void)halves.filter->candidate_log_likelihood(z + Eigen::Vector2d(3.0, -2.0) * z.norm());
      const double likelihood = halves.filter->candidate_log_likelihood(z);
      const double distance = halves.filter->candidate_distance(z);
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
        if (halves.filter->predicts_before_the_plot()) {  // else the gate is the plot-free one
          const std::optional<double> nis = last_step_nis(*halves.filter);
          ASSERT_TRUE(nis.has_value());
          EXPECT_NEAR(distance, *nis, 1e-9 * std::max(1.0, *nis));
        }
      }
      ASSERT_TRUE(Snapshot(*whole.filter) == Snapshot(*halves.filter)) << "scan " << k;
      ASSERT_EQ(whole.filter->mode_probabilities(), halves.filter->mode_probabilities());
    }
    ++split;
  }
  EXPECT_GE(split, 25);   // every kind, the nIMMs (wIMMs without fusion) among them
  EXPECT_EQ(refused, 1);  // the wIMM that fuses the azimuth (seed 004's)
}

}  // namespace
}  // namespace imm
