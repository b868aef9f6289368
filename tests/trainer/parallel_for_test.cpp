// SPDX-License-Identifier: Apache-2.0
// parallel_for on one thread (the loop without the OpenMP runtime) and on two: every item runs
// once, and a failure surfaces as the lowest failing index's exception after every item has run.
#include "imm/trainer/parallel_for.hpp"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <stdexcept>
#include <string>
#include <vector>

namespace imm::trainer {
namespace {

class ParallelFor : public ::testing::TestWithParam<int> {
 protected:
  void SetUp() override {
    threads_ = omp_get_max_threads();
    omp_set_num_threads(GetParam());
  }
  void TearDown() override { omp_set_num_threads(threads_); }

 private:
  int threads_ = 1;
};

TEST_P(ParallelFor, RunsEveryItemOnce) {
  for (const long count : {0L, 1L, 2L, 37L}) {
    std::vector<std::atomic<int>> runs(static_cast<std::size_t>(count));
    parallel_for(count, 4, [&](long i) { ++runs[static_cast<std::size_t>(i)]; });
    for (long i = 0; i < count; ++i) EXPECT_EQ(runs[static_cast<std::size_t>(i)], 1) << i;
  }
}

TEST_P(ParallelFor, RethrowsTheLowestFailingIndexAfterEveryItemRan) {
  constexpr long kCount = 50;
  std::vector<std::atomic<int>> runs(kCount);
  try {
    parallel_for(kCount, 3, [&](long i) {
      ++runs[static_cast<std::size_t>(i)];
      if (i == 41 || i == 17 || i == 29) throw std::runtime_error("item " + std::to_string(i));
    });
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "item 17");
  }
  EXPECT_TRUE(std::all_of(runs.begin(), runs.end(), [](const auto& r) { return r == 1; }));
}

INSTANTIATE_TEST_SUITE_P(Threads, ParallelFor, ::testing::Values(1, 2), [](const auto& param_info) {
  return std::to_string(param_info.param) + "Threads";
});

}  // namespace
}  // namespace imm::trainer
