// SPDX-License-Identifier: Apache-2.0
// The verdict of a comparison over several error metrics, and the rule the reports state.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <string_view>
#include <vector>

#include "imm/evaluation/uncertainty.hpp"

namespace imm::evaluation {
namespace {

constexpr Difference kVerdictBetter{-0.02, -0.03, -0.01};
constexpr Difference kVerdictWorse{+0.02, +0.01, +0.03};
constexpr Difference kVerdictTied{-0.001, -0.004, +0.002};

std::string_view of(std::initializer_list<Difference> differences) {
  const std::vector<Difference> all(differences);
  return verdict(all);
}

TEST(Verdict, FollowsTheStatedRule) {
  EXPECT_EQ(of({kVerdictBetter, kVerdictBetter}), "beats");
  EXPECT_EQ(of({kVerdictBetter, kVerdictTied}),
            "beats");  // better in ζ_v beyond the interval, ζ_p tied
  EXPECT_EQ(of({kVerdictWorse, kVerdictTied}), "loses to");
  EXPECT_EQ(of({kVerdictWorse, kVerdictWorse}), "loses to");
  EXPECT_EQ(of({kVerdictBetter, kVerdictWorse}), "mixed");  // one better and one worse is neither
  EXPECT_EQ(of({kVerdictTied, kVerdictTied}), "ties");
  EXPECT_EQ(of({}), "ties");
  // An interval that touches zero is not beyond it.
  EXPECT_EQ(of({Difference{-0.01, -0.02, 0.0}}), "ties");
  for (const char* word : {"beats", "loses to", "mixed", "ties"}) {
    EXPECT_NE(kVerdictRule.find(word), std::string_view::npos) << word;
  }
}

// The same filter computed two ways (a learned model with its learned part off, and its
// baseline) differs by rounding with one sign on every resample: that ties, it does not beat. A
// real difference of the same sign, however small against the statistic's spread, still counts.
// A difference is written with enough digits to be read: fixed decimals where they show it,
// three significant digits where every number would round to zero.
TEST(PairedDifference, ATinyDifferenceShowsItsDigits) {
  EXPECT_EQ((Difference{-0.0123, -0.0150, -0.0097}).text(), "-0.0123 [-0.0150, -0.0097]");
  EXPECT_EQ((Difference{3.2e-6, 1.1e-6, 5.04e-6}).text(), "+3.2e-06 [+1.1e-06, +5.04e-06]");
  EXPECT_EQ((Difference{0.0, 0.0, 0.0}).text(), "+0.0000 [+0.0000, +0.0000]");
  EXPECT_EQ((Difference{0.03, 0.01, 0.04}).text(1), "+0.03 [+0.01, +0.04]");
  // Decimals grow until the interval's width shows two significant digits: a kilometre RMSE's
  // difference of +0.04 [+0.002, +0.082] no longer reads "+0.0 [+0.0, +0.1]".
  EXPECT_EQ((Difference{0.4, 0.01, 0.6}).text(1), "+0.40 [+0.01, +0.60]");
  EXPECT_EQ((Difference{0.04, 0.002, 0.082}).text(1), "+0.040 [+0.002, +0.082]");
  EXPECT_EQ((Difference{1.1, 0.6, 1.5}).text(1), "+1.10 [+0.60, +1.50]");
  EXPECT_EQ((Difference{12.0, 3.0, 21.0}).text(1), "+12.0 [+3.0, +21.0]");
}

TEST(PairedDifference, RoundingLevelDifferencesTieAndRealOnesCount) {
  Eigen::VectorXd per_run(20);
  for (int i = 0; i < 20; ++i) per_run(i) = 0.75 + 0.01 * i;
  const Statistic a = mean_of(per_run);
  const Statistic rounded = mean_of(per_run * (1.0 + 4e-12));
  const Difference same = paired_difference(20, a, rounded);
  EXPECT_EQ(same.estimate, 0.0);
  EXPECT_EQ(same.lower, 0.0);
  EXPECT_EQ(same.upper, 0.0);
  EXPECT_EQ(of({same, same}), "ties");
  const Statistic better = mean_of(per_run * (1.0 + 1e-6));
  const Difference real = paired_difference(20, a, better);
  EXPECT_TRUE(real.below()) << real.text(9);
}

}  // namespace
}  // namespace imm::evaluation
