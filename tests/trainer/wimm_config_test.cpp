// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <cmath>

#include "imm/datasets/track.hpp"
#include "imm/trainer/wimm/wimm_trainer.hpp"
#include "testing/config_error.hpp"

namespace imm::trainer {
namespace {

std::string wimm_config_error(const std::string& text) {
  return testing::config_error_key("regime = \"configs/regimes/paper/wimm_training.toml\"\n" + text,
                                   [](const auto& path) { return wimm::load_wimm_config(path); });
}

TEST(WimmConfig, InvalidValuesAreNamed) {
  EXPECT_EQ(wimm_config_error("[tuning]\nalpha_range = [0.0, 1.0]\n"), "tuning.alpha_range");
  EXPECT_EQ(wimm_config_error("[filter]\nfusion = \"strong\"\n"), "filter.fusion");
  EXPECT_EQ(wimm_config_error("[filter]\nalpha = 1.5\n"), "filter.alpha");
  EXPECT_EQ(wimm_config_error("[training]\ntrajectories = 3\n"), "training");  // now the regime's
  EXPECT_EQ(wimm_config_error(""), "");
  const auto shipped = wimm::load_wimm_config("configs/wimm.toml");
  EXPECT_EQ(shipped.filter.threshold, 0.7);
  EXPECT_EQ(shipped.filter.alpha, 0.5);
  EXPECT_EQ(shipped.filter.sample_period, 2.0);
}

// The training tracks are not seed 004's: the random geometry of the training regime, seeded and
// reproducible, with T and the sensor taken into the filter.
TEST(WimmTraining, TracksComeFromTheConfigsRegime) {
  const auto config = wimm::load_wimm_config("configs/wimm.toml");
  EXPECT_EQ(config.regime.name, "wimm_training");
  EXPECT_EQ(config.filter.sample_period, config.regime.sample_period);
  EXPECT_EQ(config.filter.range_sigma, config.regime.sensor.noise.sigma(0));
  const auto a = datasets::draw_split(config.regime, datasets::Split::kTraining, 0, 5);
  const auto b = datasets::draw_split(config.regime, datasets::Split::kTraining, 0, 5);
  ASSERT_EQ(a.tracks.size(), 5u);
  EXPECT_EQ(a.tracks[3].plots, b.tracks[3].plots);
  EXPECT_NE(a.tracks[0].truth.row(0), a.tracks[1].truth.row(0));
  EXPECT_GT(std::hypot(a.tracks[2].truth(0, 0), a.tracks[2].truth(0, 3)), 79e3);
}

}  // namespace
}  // namespace imm::trainer
