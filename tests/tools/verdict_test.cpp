// SPDX-License-Identifier: Apache-2.0
// The verdict of a comparison over several error metrics, and the rule the reports state.
#include <gtest/gtest.h>

#include <string_view>
#include <vector>

#include "imm/evaluation/uncertainty.hpp"

namespace imm::evaluation {
namespace {

constexpr Difference kBetter{-0.02, -0.03, -0.01};
constexpr Difference kWorse{+0.02, +0.01, +0.03};
constexpr Difference kTied{-0.001, -0.004, +0.002};

std::string_view of(std::initializer_list<Difference> differences) {
  const std::vector<Difference> all(differences);
  return verdict(all);
}

TEST(Verdict, FollowsTheStatedRule) {
  EXPECT_EQ(of({kBetter, kBetter}), "beats");
  EXPECT_EQ(of({kBetter, kTied}), "beats");  // better in ζ_v beyond the interval, ζ_p tied
  EXPECT_EQ(of({kWorse, kTied}), "loses to");
  EXPECT_EQ(of({kWorse, kWorse}), "loses to");
  EXPECT_EQ(of({kBetter, kWorse}), "mixed");  // one better and one worse is neither
  EXPECT_EQ(of({kTied, kTied}), "ties");
  EXPECT_EQ(of({}), "ties");
  // An interval that touches zero is not beyond it.
  EXPECT_EQ(of({Difference{-0.01, -0.02, 0.0}}), "ties");
  for (const char* word : {"beats", "loses to", "mixed", "ties"}) {
    EXPECT_NE(kVerdictRule.find(word), std::string_view::npos) << word;
  }
}

}  // namespace
}  // namespace imm::evaluation
