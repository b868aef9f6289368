// SPDX-License-Identifier: Apache-2.0
#include "imm/datasets/scene.hpp"

#include <cmath>
#include <limits>
#include <utility>

#include "imm/datasets/random.hpp"

namespace imm::datasets {
namespace {

// Poisson(λ) by counting uniform arrivals (λ ≤ 10⁴: the product falls below e^(−λ) in about λ
// draws; exp(−λ) underflows only beyond 745, where the count is then drawn by halves).
int poisson(Rng& rng, double mean) {
  if (mean > 500.0) return poisson(rng, 0.5 * mean) + poisson(rng, 0.5 * mean);
  const double limit = std::exp(-mean);
  int count = 0;
  for (double product = rng.uniform(); product > limit; product *= rng.uniform()) ++count;
  return count;
}

}  // namespace

Scene draw_scene(const Regime& regime, const SceneSpec& spec, Split split, int index,
                 std::uint64_t seed) {
  spec.validate();
  Scene scene;
  for (int j = 0; j < spec.targets; ++j) {
    scene.targets.push_back(draw_track(regime, split, index * spec.targets + j, seed));
  }
  const Eigen::Index scans = scene.targets.front().plots.rows();
  // The region: the box of every target's plots, widened by a tenth on each side.
  Eigen::Vector2d low = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d high = -low;
  for (const Track& t : scene.targets) {
    for (Eigen::Index k = 0; k < t.plots.rows(); ++k) {
      if (!t.plots.row(k).allFinite()) continue;
      low = low.cwiseMin(t.plots.row(k).transpose());
      high = high.cwiseMax(t.plots.row(k).transpose());
    }
  }
  const Eigen::Vector2d margin = 0.1 * (high - low);
  scene.low = low - margin;
  scene.high = high + margin;
  Rng rng(derive_seed(seed, 1000003ULL + static_cast<std::uint64_t>(index)));
  scene.plots.resize(static_cast<std::size_t>(scans));
  scene.origins.resize(static_cast<std::size_t>(scans));
  for (Eigen::Index k = 0; k < scans; ++k) {
    std::vector<Eigen::Vector2d>& plots = scene.plots[static_cast<std::size_t>(k)];
    std::vector<int>& origins = scene.origins[static_cast<std::size_t>(k)];
    for (std::size_t j = 0; j < scene.targets.size(); ++j) {
      const Eigen::Vector2d z = scene.targets[j].plots.row(k).transpose();
      if (z.allFinite() && rng.uniform() < spec.detection_probability) {
        plots.push_back(z);
        origins.push_back(static_cast<int>(j));
      }
    }
    for (int c = poisson(rng, spec.clutter_per_scan); c > 0; --c) {
      plots.emplace_back(rng.uniform(scene.low(0), scene.high(0)),
                         rng.uniform(scene.low(1), scene.high(1)));
      origins.push_back(-1);
    }
    for (std::size_t i = plots.size(); i > 1; --i) {  // Fisher–Yates: the order tells nothing
      const auto other = static_cast<std::size_t>(rng.uniform() * static_cast<double>(i));
      std::swap(plots[i - 1], plots[other]);
      std::swap(origins[i - 1], origins[other]);
    }
  }
  return scene;
}

}  // namespace imm::datasets
