// SPDX-License-Identifier: Apache-2.0
// The gating question of a multi-target tracker — every track's log-likelihood of every plot of a
// scan — for 1 000 tracks of the W1 IMM and 100 plots: TrackBank::candidate_log_likelihoods in
// one call against a loop over one-track ImmEstimators (predict(), then per pair
// candidate_distance and, inside the gate, candidate_log_likelihood). Items: (track, plot) pairs.

#include <benchmark/benchmark.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "imm/filters/plain_imm.hpp"
#include "imm/math/chi_square.hpp"
#include "imm/tracking/track_bank.hpp"
#include "workloads.hpp"

namespace {

// Tracks on a 50 m grid; each plot near one track's predicted position (σ_z-sized noise), so a
// plot is inside the gate of about one track.
struct Scene {
  std::vector<imm::GaussianState<4>> starts;
  std::vector<Eigen::Vector2d> plots;
  Scene(std::size_t tracks, std::size_t plot_count) {
    std::mt19937_64 rng(5);
    std::normal_distribution<double> noise(0.0, 1.0);
    for (std::size_t t = 0; t < tracks; ++t) {
      imm::GaussianState<4> s = imm::workloads::w1_start();
      s.mean(0) += 50.0 * static_cast<double>(t % 40);
      s.mean(2) += 50.0 * static_cast<double>(t / 40);
      starts.push_back(s);
    }
    const double T = imm::workloads::w1_spec().sample_period;
    for (std::size_t q = 0; q < plot_count; ++q) {
      const imm::GaussianState<4>& s = starts[(q * 7919) % tracks];
      plots.emplace_back(s.mean(0) + T * s.mean(1) + noise(rng),
                         s.mean(2) + T * s.mean(3) + noise(rng));
    }
  }
};

// range(0): 0 one-track ImmEstimators, 1 TrackBank; range(1): 1 with the 99 % χ² gate, 0 every
// pair scored.
void BM_GatingMatrix(benchmark::State& state) {
  constexpr std::size_t kTracks = 1000, kPlots = 100;
  const bool bank_api = state.range(0) == 1;
  const double gate = state.range(1) == 1 ? imm::chi_square_quantile(0.99, 2)
                                          : std::numeric_limits<double>::infinity();
  const Scene scene(kTracks, kPlots);
  const auto spec = imm::workloads::w1_spec();
  Eigen::MatrixXd out(kTracks, kPlots);
  if (bank_api) {
    imm::TrackBank bank(spec, kTracks);
    for (std::size_t t = 0; t < kTracks; ++t) bank.initialize(t, scene.starts[t]);
    for (auto _ : state) {
      bank.candidate_log_likelihoods(scene.plots, gate, out);
      benchmark::DoNotOptimize(out.data());
    }
  } else {
    std::vector<imm::ImmEstimator<4, 2>> tracks;
    tracks.reserve(kTracks);
    for (std::size_t t = 0; t < kTracks; ++t) {
      tracks.push_back(imm::build_plain_imm<4>(spec));
      tracks.back().initialize(scene.starts[t]);
    }
    for (auto _ : state) {
      for (std::size_t t = 0; t < kTracks; ++t) {
        imm::ImmEstimator<4, 2>& track = tracks[t];
        track.predict();
        for (std::size_t q = 0; q < kPlots; ++q) {
          const auto& z = scene.plots[q];
          const bool inside = !(track.candidate_distance(z) > gate);
          out(static_cast<Eigen::Index>(t), static_cast<Eigen::Index>(q)) =
              inside ? track.candidate_log_likelihood(z) : -std::numeric_limits<double>::infinity();
        }
      }
      benchmark::DoNotOptimize(out.data());
    }
  }
  std::size_t inside = 0;
  for (Eigen::Index i = 0; i < out.size(); ++i) inside += std::isfinite(out.data()[i]) ? 1 : 0;
  state.counters["inside_gate"] = static_cast<double>(inside);
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(kTracks * kPlots));
  state.SetLabel(bank_api ? "TrackBank" : "one-track ImmEstimators");
}
BENCHMARK(BM_GatingMatrix)->Args({0, 1})->Args({1, 1})->Args({0, 0})->Args({1, 0});

}  // namespace
