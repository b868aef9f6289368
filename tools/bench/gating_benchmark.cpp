// SPDX-License-Identifier: Apache-2.0
// The gating question of a multi-target tracker — every track's log-likelihood of every plot of a
// scan — for 1 000 tracks and 100 plots: a bank's candidate_log_likelihoods in one call against a
// loop over one-track filters (predict(), then per pair candidate_distance and, inside the gate,
// candidate_log_likelihood). The W1 IMM (TrackBank), the shipped input estimator
// (InputEstimatorTrackBank), GA-fuzzy IMM (GaFuzzyTrackBank), FCM-IMM (FcmImmTrackBank), nIMM
// (WimmTrackBank) and FIMM (FimmTrackBank). Items: (track, plot) pairs.

#include <benchmark/benchmark.h>

#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "imm/filters/fcm_imm.hpp"
#include "imm/filters/fimm.hpp"
#include "imm/filters/ga_fuzzy_imm.hpp"
#include "imm/filters/mlp_input_estimator.hpp"
#include "imm/filters/plain_imm.hpp"
#include "imm/filters/wimm.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/io/wimm_file.hpp"
#include "imm/math/chi_square.hpp"
#include "imm/tracking/fcm_imm_track_bank.hpp"
#include "imm/tracking/fimm_track_bank.hpp"
#include "imm/tracking/ga_fuzzy_track_bank.hpp"
#include "imm/tracking/input_estimator_track_bank.hpp"
#include "imm/tracking/track_bank.hpp"
#include "imm/tracking/wimm_track_bank.hpp"
#include "workloads.hpp"

namespace {

// Tracks on a 50 m grid; each plot near one track's predicted position (σ_z-sized noise), so a
// plot is inside the gate of about one track.
struct Scene {
  std::vector<imm::GaussianState<4>> starts;
  std::vector<Eigen::Vector2d> plots;
  // T: the sample period the plots are predicted over.
  Scene(std::size_t tracks, std::size_t plot_count, double T) {
    std::mt19937_64 rng(5);
    std::normal_distribution<double> noise(0.0, 1.0);
    for (std::size_t t = 0; t < tracks; ++t) {
      imm::GaussianState<4> s = imm::workloads::w1_start();
      const std::size_t column = t % 40, row = t / 40;  // the grid's cell
      s.mean(0) += 50.0 * static_cast<double>(column);
      s.mean(2) += 50.0 * static_cast<double>(row);
      starts.push_back(s);
    }
    for (std::size_t q = 0; q < plot_count; ++q) {
      const imm::GaussianState<4>& s = starts[(q * 7919) % tracks];
      plots.emplace_back(s.mean(0) + T * s.mean(1) + noise(rng),
                         s.mean(2) + T * s.mean(3) + noise(rng));
    }
  }
};

// A one-track filter, held by value or by pointer, started from `s`.
void start(imm::ImmEstimator<4, 2>& track, const imm::GaussianState<4>& s) { track.initialize(s); }
template <class Filter, class State>
void start(std::unique_ptr<Filter>& track, const State& s) {
  track->initialize(s.mean, s.covariance);
}
imm::ImmEstimator<4, 2>& held(imm::ImmEstimator<4, 2>& track) { return track; }
template <class Filter>
Filter& held(std::unique_ptr<Filter>& track) {
  return *track;
}

// range(0): 0 a loop over one-track filters (make_track()), 1 a bank (make_bank()); range(1): 1
// with the 99 % χ² gate, 0 every pair scored.
template <class State, class MakeBank, class MakeTrack>
void gating_matrix(benchmark::State& state, const std::vector<Eigen::Vector2d>& candidates,
                   const std::vector<State>& starts, MakeBank&& make_bank, MakeTrack&& make_track,
                   const char* bank_label, const char* loop_label) {
  const bool bank_api = state.range(0) == 1;
  const double gate = state.range(1) == 1 ? imm::chi_square_quantile(0.99, 2)
                                          : std::numeric_limits<double>::infinity();
  const std::size_t tracks = starts.size(), plots = candidates.size();
  Eigen::MatrixXd out(static_cast<Eigen::Index>(tracks), static_cast<Eigen::Index>(plots));
  if (bank_api) {
    auto bank = make_bank();
    for (std::size_t t = 0; t < tracks; ++t) bank.initialize(t, starts[t]);
    for (auto _ : state) {
      bank.candidate_log_likelihoods(candidates, gate, out);
      benchmark::DoNotOptimize(out.data());
    }
  } else {
    std::vector<decltype(make_track())> one;
    one.reserve(tracks);
    for (std::size_t t = 0; t < tracks; ++t) {
      one.push_back(make_track());
      start(one.back(), starts[t]);
    }
    for (auto _ : state) {
      for (std::size_t t = 0; t < tracks; ++t) {
        auto& track = held(one[t]);
        (void)track.predict();
        for (std::size_t q = 0; q < plots; ++q) {
          const auto& z = candidates[q];
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
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(tracks * plots));
  state.SetLabel(bank_api ? bank_label : loop_label);
}

constexpr std::size_t kTracks = 1000, kPlots = 100;

// The W1 IMM: TrackBank against one-track ImmEstimators.
void BM_GatingMatrix(benchmark::State& state) {
  const auto spec = imm::workloads::w1_spec();
  const Scene scene(kTracks, kPlots, spec.sample_period);
  gating_matrix(
      state, scene.plots, scene.starts, [&] { return imm::TrackBank(spec, kTracks); },
      [&] { return imm::build_plain_imm<4>(spec); }, "TrackBank", "one-track ImmEstimators");
}
BENCHMARK(BM_GatingMatrix)->Args({0, 1})->Args({1, 1})->Args({0, 0})->Args({1, 0});

// The shipped input estimator (models/mlp_input_estimator.h5): InputEstimatorTrackBank against
// one-track filters (make_mlp_input_estimator_filter).
void BM_InputEstimatorGatingMatrix(benchmark::State& state) {
  const imm::MlpInputEstimatorModel model =
      imm::io::read_mlp_input_estimator(IMM_SOURCE_DIR "/models/mlp_input_estimator.h5");
  const Scene scene(kTracks, kPlots, model.settings.sample_period);
  gating_matrix(
      state, scene.plots, scene.starts,
      [&] { return imm::InputEstimatorTrackBank(model, kTracks); },
      [&] { return imm::make_mlp_input_estimator_filter(model); }, "InputEstimatorTrackBank",
      "one-track input estimators");
}
BENCHMARK(BM_InputEstimatorGatingMatrix)->Args({0, 1})->Args({1, 1})->Args({0, 0})->Args({1, 0});

// The shipped GA-fuzzy IMM (models/ga_fuzzy_imm.h5): GaFuzzyTrackBank against one-track filters
// (make_ga_fuzzy_imm_filter), both scoring a candidate by a trial step of every mode.
void BM_GaFuzzyGatingMatrix(benchmark::State& state) {
  const imm::GaFuzzyImmSpec spec =
      imm::io::read_ga_fuzzy_imm(IMM_SOURCE_DIR "/models/ga_fuzzy_imm.h5");
  const Scene scene(kTracks, kPlots, spec.settings.sample_period);
  gating_matrix(
      state, scene.plots, scene.starts, [&] { return imm::GaFuzzyTrackBank(spec, kTracks); },
      [&] { return imm::make_ga_fuzzy_imm_filter(spec); }, "GaFuzzyTrackBank",
      "one-track GA-fuzzy IMMs");
}
BENCHMARK(BM_GaFuzzyGatingMatrix)->Args({0, 1})->Args({1, 1})->Args({0, 0})->Args({1, 0});

// The shipped FCM-IMM (models/fcm_imm.h5): FcmImmTrackBank against one-track filters
// (make_fcm_imm_filter), both scoring a candidate by a trial step of every mode (the window's
// clustering of the candidate's error included).
void BM_FcmImmGatingMatrix(benchmark::State& state) {
  const imm::FcmImmSpec spec = imm::io::read_fcm_imm(IMM_SOURCE_DIR "/models/fcm_imm.h5");
  const Scene scene(kTracks, kPlots, spec.sample_period);
  gating_matrix(
      state, scene.plots, scene.starts, [&] { return imm::FcmImmTrackBank(spec, kTracks); },
      [&] { return imm::make_fcm_imm_filter(spec); }, "FcmImmTrackBank", "one-track FCM-IMMs");
}
BENCHMARK(BM_FcmImmGatingMatrix)->Args({0, 1})->Args({1, 1})->Args({0, 0})->Args({1, 0});

// The air_surveillance regime's nIMM (models/baseline_nimm_air_surveillance.h5, polar plots):
// WimmTrackBank against one-track WimmFilters. The scene's tracks sit 30–40 km out on a 500 m
// grid (range and azimuth plots).
void BM_NimmGatingMatrix(benchmark::State& state) {
  const imm::WimmSpec spec =
      imm::io::read_wimm(IMM_SOURCE_DIR "/models/baseline_nimm_air_surveillance.h5");
  Scene scene(kTracks, kPlots, spec.sample_period);
  for (imm::GaussianState<4>& s : scene.starts) {
    s.mean(0) = 10.0 * s.mean(0) + 30000.0;
    s.mean(2) = 10.0 * s.mean(2) + 30000.0;
  }
  std::vector<imm::GaussianState<6>> starts;
  for (const imm::GaussianState<4>& s : scene.starts) {
    imm::GaussianState<6> six;
    six.mean << s.mean(0), s.mean(1), 0.0, s.mean(2), s.mean(3), 0.0;
    six.covariance =
        (Eigen::Matrix<double, 6, 1>() << 2e4, 400.0, 9.0, 2e4, 400.0, 9.0).finished().asDiagonal();
    starts.push_back(six);
  }
  for (std::size_t q = 0; q < kPlots; ++q) {
    const imm::GaussianState<6>& s = starts[(q * 7919) % kTracks];
    const double x = s.mean(0) + spec.sample_period * s.mean(1);
    const double y = s.mean(3) + spec.sample_period * s.mean(4);
    scene.plots[q] = Eigen::Vector2d(std::hypot(x, y), std::atan2(x, y));
  }
  gating_matrix(
      state, scene.plots, starts, [&] { return imm::WimmTrackBank(spec, kTracks); },
      [&] { return std::make_unique<imm::WimmFilter>(spec); }, "WimmTrackBank",
      "one-track WimmFilters");
}
BENCHMARK(BM_NimmGatingMatrix)->Args({0, 1})->Args({1, 1})->Args({0, 0})->Args({1, 0});

// The shipped FIMM (models/tsk_range_sensor.h5: its TSK sensor model and FIMM settings):
// FimmTrackBank against one-track FimmFilters. The scene's tracks and plots in the sensor's
// plane.
void BM_FimmGatingMatrix(benchmark::State& state) {
  const imm::io::ModelFileReader reader(IMM_SOURCE_DIR "/models/tsk_range_sensor.h5");
  const auto sensor = std::make_shared<const imm::TskSensorModel>(imm::io::read_tsk_sensor(reader));
  const imm::FimmSpec spec = imm::io::read_fimm_settings(reader).value();
  // Tracks on a 40 × 25 grid over the sensor's trained box, still; each plot the sensor's
  // reading of one track's position.
  const Eigen::Vector2d lower = sensor->input_lower(), upper = sensor->input_upper();
  std::vector<imm::GaussianState<6>> starts;
  for (std::size_t t = 0; t < kTracks; ++t) {
    const double u = (static_cast<double>(t % 40) + 0.5) / 40.0;
    const double v =
        (static_cast<double>(t / 40) + 0.5) / 25.0;  // NOLINT(bugprone-integer-division)
    imm::GaussianState<6> s;
    s.mean << lower(0) + u * (upper(0) - lower(0)), 0.0, 0.0, lower(1) + v * (upper(1) - lower(1)),
        0.0, 0.0;
    s.covariance = imm::Vector<6>(1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4).asDiagonal();
    starts.push_back(s);
  }
  std::vector<Eigen::Vector2d> plots;
  for (std::size_t q = 0; q < kPlots; ++q) {
    const imm::GaussianState<6>& s = starts[(q * 7919) % kTracks];
    plots.push_back(sensor->evaluate(Eigen::Vector2d(s.mean(0), s.mean(3))).value);
  }
  gating_matrix(
      state, plots, starts, [&] { return imm::FimmTrackBank(spec, sensor, kTracks); },
      [&] { return std::make_unique<imm::FimmFilter>(spec, sensor); }, "FimmTrackBank",
      "one-track FimmFilters");
}
BENCHMARK(BM_FimmGatingMatrix)->Args({0, 1})->Args({1, 1})->Args({0, 0})->Args({1, 0});

}  // namespace
