// SPDX-License-Identifier: Apache-2.0
// Scenes of several targets among clutter (imm/datasets/scene.hpp): reproducible, every detection
// its target's own plot, the detection rate Pd and the clutter Poisson(λ) per scan within their
// sampling error, false plots inside the scene's box; a regime's [scene] read with its defaults.

#include "imm/datasets/scene.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "imm/core/invalid_parameter.hpp"
#include "imm/datasets/regime_file.hpp"

namespace imm::datasets {
namespace {

TEST(Scene, ReproducibleWithItsDetectionRateAndClutterDensity) {
  const Regime regime = load_regime("configs/regimes/agile_air.toml").regime;
  EXPECT_EQ(regime.scene.targets, 3);  // no [scene]: the defaults
  const SceneSpec spec{3, 0.8, 5.0};
  double detected = 0.0, chances = 0.0, clutter = 0.0, scans = 0.0, clutter_square = 0.0;
  for (int i = 0; i < 20; ++i) {
    const Scene a = draw_scene(regime, spec, Split::kTest, i, 7);
    const Scene b = draw_scene(regime, spec, Split::kTest, i, 7);
    ASSERT_EQ(a.plots, b.plots);
    ASSERT_EQ(a.origins, b.origins);
    ASSERT_EQ(a.targets.size(), 3U);
    // The targets are the split's own tracks 3i, 3i + 1, 3i + 2.
    EXPECT_EQ(a.targets[1].plots, draw_track(regime, Split::kTest, 3 * i + 1, 7).plots);
    for (std::size_t k = 0; k < a.plots.size(); ++k) {
      ASSERT_EQ(a.plots[k].size(), a.origins[k].size());
      double false_plots = 0.0;
      for (std::size_t p = 0; p < a.plots[k].size(); ++p) {
        const int origin = a.origins[k][p];
        if (origin >= 0) {
          EXPECT_EQ(a.plots[k][p], a.targets[static_cast<std::size_t>(origin)]
                                       .plots.row(static_cast<Eigen::Index>(k))
                                       .transpose());
          detected += 1.0;
        } else {
          false_plots += 1.0;
          EXPECT_TRUE((a.plots[k][p].array() >= a.low.array()).all());
          EXPECT_TRUE((a.plots[k][p].array() <= a.high.array()).all());
        }
      }
      for (const Track& t : a.targets) {
        chances += t.plots.row(static_cast<Eigen::Index>(k)).allFinite() ? 1.0 : 0.0;
      }
      clutter += false_plots;
      clutter_square += false_plots * false_plots;
      scans += 1.0;
    }
  }
  // Binomial and Poisson sampling errors, 4σ.
  EXPECT_NEAR(detected / chances, 0.8, 4.0 * std::sqrt(0.8 * 0.2 / chances));
  const double mean = clutter / scans;
  EXPECT_NEAR(mean, 5.0, 4.0 * std::sqrt(5.0 / scans));
  EXPECT_NEAR(clutter_square / scans - mean * mean, 5.0, 1.0);  // Poisson: variance = mean
  // Another seed, other scenes.
  EXPECT_NE(draw_scene(regime, spec, Split::kTest, 0, 8).plots,
            draw_scene(regime, spec, Split::kTest, 0, 7).plots);
}

TEST(Scene, DenseClutterStaysPoissonAndBadSettingsNameTheirKey) {
  const Regime regime = load_regime("configs/regimes/agile_air.toml").regime;
  const Scene dense = draw_scene(regime, SceneSpec{1, 1.0, 900.0}, Split::kTest, 0, 3);
  double clutter = 0.0;
  for (const auto& origins : dense.origins) {
    for (const int origin : origins) clutter += origin < 0 ? 1.0 : 0.0;
  }
  const double scans = static_cast<double>(dense.origins.size());
  EXPECT_NEAR(clutter / scans, 900.0, 4.0 * std::sqrt(900.0 / scans));
  try {
    (void)draw_scene(regime, SceneSpec{2, 0.0, 1.0}, Split::kTest, 0, 3);
    ADD_FAILURE() << "Pd 0 accepted";
  } catch (const InvalidParameter& error) {
    EXPECT_EQ(error.field(), "scene.detection_probability");
  }
}

}  // namespace
}  // namespace imm::datasets
