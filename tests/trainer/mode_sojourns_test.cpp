// SPDX-License-Identifier: Apache-2.0
// Mean sojourn times learned from labeled tracks: sequences drawn from a continuous-time chain of
// known rates (exponential sojourns, sampled every T) give them back within their sampling error.
#include "imm/trainer/mode_sojourns.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/random.hpp"

namespace imm::trainer {
namespace {

// A two-mode chain in continuous time, its state read at t = 0, T, 2T, …
std::vector<int> sampled_chain(datasets::Rng& rng, const double (&mean_sojourn)[2], int scans,
                               double T) {
  std::vector<int> labels(static_cast<std::size_t>(scans));
  int mode = rng.uniform(0.0, 1.0) < 0.5 ? 0 : 1;
  double next_switch = -mean_sojourn[mode] * std::log(1.0 - rng.uniform(0.0, 1.0));
  for (int k = 0; k < scans; ++k) {
    const double t = k * T;
    while (t >= next_switch) {
      mode = 1 - mode;
      next_switch += -mean_sojourn[mode] * std::log(1.0 - rng.uniform(0.0, 1.0));
    }
    labels[static_cast<std::size_t>(k)] = mode;
  }
  return labels;
}

TEST(ModeSojourns, RecoverKnownMeanSojournTimesWithinTheirSamplingError) {
  const double tau[2] = {40.0, 12.0};
  for (const double T : {1.0, 5.0}) {  // 5 s: several switches can fall between two samples
    datasets::Rng rng(31);
    std::vector<std::vector<int>> labels;
    for (int track = 0; track < 300; ++track) labels.push_back(sampled_chain(rng, tau, 400, T));
    const SojournEstimate e = estimate_sojourns(labels, 2, T);
    for (int i = 0; i < 2; ++i) {
      EXPECT_GT(e.exits(i), 1000) << i;
      EXPECT_NEAR(e.mean_sojourn(i), tau[i], 3.0 * e.standard_error(i))
          << "mode " << i << ", T " << T << ": " << e.mean_sojourn(i) << " ± "
          << e.standard_error(i);
    }
    EXPECT_NEAR(e.generator.row(0).sum(), 0.0, 1e-15);
    EXPECT_NEAR(e.generator.row(1).sum(), 0.0, 1e-15);
  }
}

TEST(ModeSojourns, BadLabelsAreRefusedNamingThem) {
  const std::vector<std::vector<int>> out_of_range = {{0, 1, 2}};
  EXPECT_THROW((void)estimate_sojourns(out_of_range, 2, 1.0), InvalidParameter);
  const std::vector<std::vector<int>> one_mode = {{0, 0, 0}};
  try {
    (void)estimate_sojourns(one_mode, 2, 1.0);
    ADD_FAILURE();
  } catch (const InvalidParameter& error) {
    EXPECT_EQ(error.field(), "labels");
  }
  const std::vector<std::vector<int>> fine = {{0, 1, 0, 1}};
  EXPECT_THROW((void)estimate_sojourns(fine, 2, 0.0), InvalidParameter);
}

}  // namespace
}  // namespace imm::trainer
