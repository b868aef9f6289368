// SPDX-License-Identifier: Apache-2.0
// Many tracks per call (imm/tracking/): the banks of the plain IMM, the GA-fuzzy IMM, the input
// estimator, the weighted IMM, the FIMM and the FCM-IMM against as many one-track filters (Google
// Benchmark; `make bench`).

#include <benchmark/benchmark.h>

#include <array>
#include <memory>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

#include "bench_inputs.hpp"
#include "imm/calibrated_track_bank.hpp"
#include "imm/filters/fcm_imm.hpp"
#include "imm/filters/fimm.hpp"
#include "imm/filters/ga_fuzzy_imm.hpp"
#include "imm/filters/mlp_input_estimator.hpp"
#include "imm/filters/plain_imm.hpp"
#include "imm/filters/wimm.hpp"
#include "imm/io/fcm_imm_file.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/io/mlp_input_estimator_file.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/plain_imm_file.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/io/wimm_file.hpp"
#include "imm/tracking/fcm_imm_track_bank.hpp"
#include "imm/tracking/fimm_track_bank.hpp"
#include "imm/tracking/ga_fuzzy_track_bank.hpp"
#include "imm/tracking/input_estimator_track_bank.hpp"
#include "imm/tracking/plain_imm_track_bank.hpp"
#include "imm/tracking/track_bank.hpp"
#include "imm/tracking/wimm_track_bank.hpp"

namespace {

using imm::TrackFilter;
using imm::bench::table3_plots;
using imm::bench::w1_input;

// W1 through the multi-track API with one track (imm/tracking/track_bank.hpp).
void BM_W1_TrackBankOneTrack(benchmark::State& state) {
  const auto& input = w1_input();
  imm::TrackBank bank(imm::workloads::w1_spec(), 1);
  bank.initialize(0, imm::workloads::w1_start());
  std::array<Eigen::Vector2d, 1> plot;
  std::array<imm::StepStatus, 1> status{};
  Eigen::Index k = 0;
  for (auto _ : state) {
    plot[0] = input.plots.row(k).transpose();
    bank.step(plot, status);
    benchmark::DoNotOptimize(status.data());
    if (++k == input.plots.rows()) {
      k = 0;
      bank.initialize(0, imm::workloads::w1_start());
    }
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_W1_TrackBankOneTrack);

// N tracks of the W1 IMM, each fed the W1 plots shifted by its own offset (so the tracks differ):
// range(1) = 0 as N separate ImmEstimators, 1 as one TrackBank. Items: track steps.
void BM_MultiTrack(benchmark::State& state) {
  const auto tracks = static_cast<std::size_t>(state.range(0));
  const bool bank_api = state.range(1) == 1;
  const auto& input = w1_input();
  const auto spec = imm::workloads::w1_spec();
  std::vector<Eigen::Vector2d> offsets(tracks);
  for (std::size_t t = 0; t < tracks; ++t)
    offsets[t] = Eigen::Vector2d(0.37 * static_cast<double>(t), -0.21 * static_cast<double>(t));
  auto start = [&](std::size_t t) {
    imm::GaussianState<4> s = imm::workloads::w1_start();
    s.mean(0) += offsets[t](0);
    s.mean(2) += offsets[t](1);
    return s;
  };
  std::vector<imm::ImmEstimator<4, 2>> separate;
  std::unique_ptr<imm::TrackBank> bank;
  if (bank_api) {
    bank = std::make_unique<imm::TrackBank>(spec, tracks);
    for (std::size_t t = 0; t < tracks; ++t) bank->initialize(t, start(t));
  } else {
    separate.reserve(tracks);
    for (std::size_t t = 0; t < tracks; ++t) {
      separate.push_back(imm::build_plain_imm<4>(spec));
      separate.back().initialize(start(t));
    }
  }
  std::vector<Eigen::Vector2d> plots(tracks);
  std::vector<imm::StepStatus> status(tracks);
  Eigen::Index k = 0;
  for (auto _ : state) {
    const Eigen::Vector2d z = input.plots.row(k).transpose();
    for (std::size_t t = 0; t < tracks; ++t) plots[t] = z + offsets[t];
    if (bank_api) {
      bank->step(plots, status);
    } else {
      for (std::size_t t = 0; t < tracks; ++t) status[t] = separate[t].step(plots[t]);
    }
    benchmark::DoNotOptimize(status.data());
    if (++k == input.plots.rows()) {
      k = 0;
      for (std::size_t t = 0; t < tracks; ++t) {
        if (bank_api) {
          bank->initialize(t, start(t));
        } else {
          separate[t].initialize(start(t));
        }
      }
    }
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(tracks));
  state.SetLabel(bank_api ? "TrackBank" : "separate ImmEstimators");
}
// What a covariance calibration costs a bank's step (imm/calibrated_track_bank.hpp): 1 000 tracks
// of W1 fed the W1 plots shifted per track, through TrackBank (kind 0; the calibration of
// classical_imm_agile_air.h5), or a shipped agile_air model through its bank: the CV/CA/CT IMM's
// general bank (1), the input estimator's (2), the GA-fuzzy IMM's (3) and the FCM-IMM's (4) lane
// banks; each plain (calibrated 0) or calibrated (1: the per-step NIS and features).
void BM_CalibratedBankStep(benchmark::State& state) {
  constexpr std::size_t kTracks = 1000;
  const bool calibrated = state.range(1) == 1;
  static constexpr std::array<const char*, 5> kModels = {
      "classical_imm_agile_air", "classical_imm_agile_air", "mlp_input_estimator_agile_air",
      "ga_fuzzy_imm_agile_air", "fcm_imm_agile_air"};
  static constexpr std::array<const char*, 5> kLabels = {"TrackBank (W1)", "PlainImmTrackBank<7>",
                                                         "InputEstimatorTrackBank",
                                                         "GaFuzzyTrackBank", "FcmImmTrackBank"};
  const auto kind = static_cast<std::size_t>(state.range(0));
  const std::string model = std::string(IMM_SOURCE_DIR "/models/") + kModels.at(kind) + ".h5";
  std::unique_ptr<imm::AnyTrackBank> owner;
  if (kind == 0) {
    owner =
        std::make_unique<imm::TrackBankAdapter<imm::TrackBank>>(imm::workloads::w1_spec(), kTracks);
    if (calibrated) {
      auto table = imm::read_calibration(imm::io::ModelFileReader(model));
      owner = std::make_unique<imm::CalibratedTrackBank>(std::move(owner), std::move(table));
    }
  } else {
    owner = imm::open_track_bank(model, kTracks);  // calibrated: the file carries a calibration
  }
  // The plain rows step the bank the calibration wraps.
  imm::AnyTrackBank* bank = owner.get();
  if (!calibrated && kind != 0) bank = &dynamic_cast<imm::CalibratedTrackBank&>(*owner).inner();
  const auto& input = w1_input();
  const int n = bank->state_dimension();
  const auto start = [&](std::size_t t) {
    const imm::GaussianState<4> w1 = imm::workloads::w1_start();
    Eigen::VectorXd mean = Eigen::VectorXd::Zero(n);
    Eigen::MatrixXd covariance = Eigen::MatrixXd::Identity(n, n);
    const int y = n == 4 || n == 5 ? 2 : 3;  // plain_imm.hpp's layouts
    for (int a = 0; a < 2; ++a) {
      mean(a) = w1.mean(a);
      mean(y + a) = w1.mean(2 + a);
      for (int c = 0; c < 2; ++c) {
        covariance(a, c) = w1.covariance(a, c);
        covariance(y + a, y + c) = w1.covariance(2 + a, 2 + c);
      }
    }
    mean(0) += 0.37 * static_cast<double>(t);
    mean(y) -= 0.21 * static_cast<double>(t);
    bank->initialize(t, mean, covariance);
  };
  for (std::size_t t = 0; t < kTracks; ++t) start(t);
  std::vector<Eigen::Vector2d> plots(kTracks);
  std::vector<imm::StepStatus> status(kTracks);
  Eigen::Index k = 0;
  for (auto _ : state) {
    const Eigen::Vector2d z = input.plots.row(k).transpose();
    for (std::size_t t = 0; t < kTracks; ++t) {
      plots[t] = z + Eigen::Vector2d(0.37 * static_cast<double>(t), -0.21 * static_cast<double>(t));
    }
    bank->step(plots, status);
    benchmark::DoNotOptimize(status.data());
    if (++k == input.plots.rows()) {
      k = 0;
      for (std::size_t t = 0; t < kTracks; ++t) start(t);
    }
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(kTracks));
  state.SetLabel(std::string(kLabels.at(kind)) + (calibrated ? ", calibrated" : ""));
}
BENCHMARK(BM_CalibratedBankStep)->ArgsProduct({{0, 1, 2, 3, 4}, {0, 1}});

// The small banks (1 to 8 tracks: fewer than a block's packs, the tail's own code) beside as many
// separate filters, then the large ones.
BENCHMARK(BM_MultiTrack)
    ->ArgsProduct({{1, 2, 3, 4, 5, 6, 7, 8}, {0, 1}})
    ->Args({1000, 0})
    ->Args({1000, 1})
    ->Args({16, 1})
    ->Args({1024, 1})  // a power of two: the state in tiles keeps a pack's slots in one run
    ->Args({10000, 1});

// `bank` through the covariance calibration of the model file at `path`.
std::unique_ptr<imm::AnyTrackBank> calibrated(std::unique_ptr<imm::AnyTrackBank> bank,
                                              const std::string& path) {
  return std::make_unique<imm::CalibratedTrackBank>(
      std::move(bank), imm::read_calibration(imm::io::ModelFileReader(path)));
}

// The benchmark loop of a bank against one-track filters: N tracks, track t fed the plots of
// `source` (from its second row) shifted by t · offset, restarted from start(t) at the end of
// `source`; `bank` null runs N filters from make_filter() instead. Items: track steps; the counter
// `ok`: the share of steps whose status was kOk (1 where every step did its work; a share of
// refusals would read 0 in every row, and its coefficient of variation 0/0 is no JSON number).
template <class Bank, class MakeFilter, class Start>
void step_tracks(benchmark::State& state, std::size_t tracks, std::unique_ptr<Bank> bank,
                 MakeFilter&& make_filter, const Eigen::MatrixXd& source,
                 const Eigen::Vector2d& offset, Start&& start) {
  std::vector<std::unique_ptr<TrackFilter>> separate;
  if (!bank) {
    for (std::size_t t = 0; t < tracks; ++t) separate.push_back(make_filter());
  }
  auto restart = [&] {
    for (std::size_t t = 0; t < tracks; ++t) {
      if constexpr (std::is_same_v<Bank, imm::AnyTrackBank>) {
        if (bank) bank->initialize(t, start(t).mean, start(t).covariance);
      } else if (bank) {
        bank->initialize(t, start(t));
      }
      if (!bank) {
        separate[t]->initialize(start(t).mean, start(t).covariance);
      }
    }
  };
  restart();
  std::vector<Eigen::Vector2d> plots(tracks);
  std::vector<imm::StepStatus> status(tracks);
  Eigen::Index k = 1;
  std::int64_t ok = 0;
  for (auto _ : state) {
    for (std::size_t t = 0; t < tracks; ++t)
      plots[t] = source.row(k).transpose() + static_cast<double>(t) * offset;
    if (bank) {
      bank->step(plots, status);
    } else {
      for (std::size_t t = 0; t < tracks; ++t) status[t] = separate[t]->step(plots[t]);
    }
    benchmark::DoNotOptimize(status.data());
    for (const imm::StepStatus s : status) ok += s == imm::StepStatus::kOk ? 1 : 0;
    if (++k == source.rows()) {
      k = 1;
      restart();
    }
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(tracks));
  state.counters["ok"] =
      static_cast<double>(ok) /
      static_cast<double>(state.iterations() * static_cast<std::int64_t>(tracks));
}

// N tracks of the GA-fuzzy IMM, each fed the seed-000 plots shifted by its own offset:
// range(1) = 0 as N one-track filters (make_ga_fuzzy_imm_filter), 1 as one GaFuzzyTrackBank;
// range(2) = 0 the shipped tables, 1 seed 000's published ones. Items: track steps.
void BM_GaFuzzyMultiTrack(benchmark::State& state) {
  const auto tracks = static_cast<std::size_t>(state.range(0));
  const bool bank_api = state.range(1) == 1;
  const auto spec = imm::io::read_ga_fuzzy_imm(
      state.range(2) == 0 ? IMM_SOURCE_DIR "/models/ga_fuzzy_imm.h5"
                          : IMM_SOURCE_DIR "/models/reference/ga_fuzzy_imm_paper.h5");
  const Eigen::MatrixXd& source = table3_plots();
  const Eigen::Vector2d offset(0.37, -0.21);
  auto start = [&](std::size_t t) {
    imm::GaussianState<4> s;
    s.mean << source(0, 0) + offset.x() * static_cast<double>(t), 0.0,
        source(0, 1) + offset.y() * static_cast<double>(t), 0.0;
    s.covariance = Eigen::Vector4d(0.25, 0.5, 0.25, 0.5).asDiagonal();
    return s;
  };
  step_tracks(
      state, tracks, bank_api ? std::make_unique<imm::GaFuzzyTrackBank>(spec, tracks) : nullptr,
      [&] { return imm::make_ga_fuzzy_imm_filter(spec); }, source, offset, start);
  state.SetLabel(std::string(bank_api ? "GaFuzzyTrackBank" : "separate filters") +
                 (state.range(2) == 0 ? ", shipped tables" : ", paper tables"));
}
BENCHMARK(BM_GaFuzzyMultiTrack)
    ->Args({1000, 0, 0})
    ->Args({1000, 1, 0})
    ->Args({1000, 0, 1})
    ->Args({1000, 1, 1})
    // A power of two: LaneStorage's stride keeps a pack's slots in different cache sets.
    ->Args({1024, 1, 0});

// N tracks of the shipped input estimator (seed 001's model, R = 50² m²), each a target at
// 300 m/s that turns at 20 m/s² for 20 of every 60 scans, the same noise per scan shifted by the
// track's offset: range(1) = 0 as N one-track filters (make_mlp_input_estimator_filter), 1 as one
// InputEstimatorTrackBank. Items: track steps.
void BM_InputEstimatorMultiTrack(benchmark::State& state) {
  const auto tracks = static_cast<std::size_t>(state.range(0));
  const bool bank_api = state.range(1) == 1;
  const auto model =
      imm::io::read_mlp_input_estimator(IMM_SOURCE_DIR "/models/mlp_input_estimator.h5");
  constexpr int kScans = 600;
  Eigen::MatrixXd source(kScans, 2);
  std::mt19937_64 rng(1);
  std::normal_distribution<double> noise(0.0, 50.0);
  Eigen::Vector2d position(0.0, 0.0), velocity(300.0, 0.0);
  for (int k = 0; k < kScans; ++k) {
    const bool turning = k % 60 >= 40;
    const Eigen::Vector2d normal(-velocity.y(), velocity.x());
    const Eigen::Vector2d a =
        turning ? Eigen::Vector2d(20.0 * normal / normal.norm()) : Eigen::Vector2d::Zero();
    position += velocity + 0.5 * a;
    velocity += a;
    source.row(k) = (position + Eigen::Vector2d(noise(rng), noise(rng))).transpose();
  }
  const Eigen::Vector2d offset(37.0, -21.0);
  auto start = [&](std::size_t t) {
    imm::GaussianState<4> s;
    s.mean << source(0, 0) + offset.x() * static_cast<double>(t), 300.0,
        source(0, 1) + offset.y() * static_cast<double>(t), 0.0;
    s.covariance = Eigen::Vector4d(2500.0, 5000.0, 2500.0, 5000.0).asDiagonal();
    return s;
  };
  step_tracks(
      state, tracks,
      bank_api ? std::make_unique<imm::InputEstimatorTrackBank>(model, tracks) : nullptr,
      [&] { return imm::make_mlp_input_estimator_filter(model); }, source, offset, start);
  state.SetLabel(bank_api ? "InputEstimatorTrackBank" : "separate filters");
}
BENCHMARK(BM_InputEstimatorMultiTrack)->Args({1000, 0})->Args({1000, 1});

// N tracks of seed 004's weighted IMM on its scenario-1 plots (a target 140 km out, T = 2 s), the
// range shifted by 3.7 m and the azimuth by 10 µrad per track: range(1) = 0 as N WimmFilters, 1 as
// one WimmTrackBank, 2 as that bank through the file's covariance calibration (CalibratedTrackBank:
// each step's NIS and features); range(2) = 0 the shipped model (models/wimm.h5: the seed's
// fusion), 1 the same spec with the correlated fusion fusing on every scan. Items: track steps.
void BM_WimmMultiTrack(benchmark::State& state) {
  const auto tracks = static_cast<std::size_t>(state.range(0));
  const bool bank_api = state.range(1) >= 1;
  imm::WimmSpec spec = imm::io::read_wimm(IMM_SOURCE_DIR "/models/wimm.h5");
  if (state.range(2) == 1) {
    spec.fusion = imm::FusionVariant::kCorrelated;
    spec.threshold = 0.0;
  }
  static const Eigen::MatrixXd source = imm::bench::preset_track("wimm_table2", 0).plots;
  const Eigen::Vector2d offset(3.7, 1e-5);
  auto start = [&](std::size_t) {
    imm::GaussianState<6> s;
    s.mean << 99000.0, -100.0, 0.0, 99000.0, -100.0, 0.0;
    s.covariance = (Eigen::Matrix<double, 6, 1>() << 2500.0, 100.0, 25.0, 2500.0, 100.0, 25.0)
                       .finished()
                       .asDiagonal();
    return s;
  };
  const auto make_filter = [&] { return std::make_unique<imm::WimmFilter>(spec); };
  if (state.range(1) == 2) {
    step_tracks(
        state, tracks,
        calibrated(std::make_unique<imm::TrackBankAdapter<imm::WimmTrackBank>>(spec, tracks),
                   IMM_SOURCE_DIR "/models/wimm.h5"),
        make_filter, source, offset, start);
  } else {
    step_tracks(state, tracks,
                bank_api ? std::make_unique<imm::WimmTrackBank>(spec, tracks) : nullptr,
                make_filter, source, offset, start);
  }
  state.SetLabel(std::string(bank_api ? "WimmTrackBank" : "separate filters") +
                 (state.range(2) == 0 ? ", shipped model" : ", correlated fusion") +
                 (state.range(1) == 2 ? ", calibrated" : ""));
}
BENCHMARK(BM_WimmMultiTrack)
    ->Args({1000, 0, 0})
    ->Args({1000, 1, 0})
    ->Args({1000, 2, 0})
    ->Args({1000, 0, 1})
    ->Args({1000, 1, 1})
    ->Args({1024, 1, 0});

// N tracks of seed 002's FIMM with the shipped sensor (models/tsk_range_sensor.h5) on the cut-in
// plots (R = 0.5² I, the presets' case 1), shifted by 1 mm along and 2 cm ahead per track:
// range(1) = 0 as N FimmFilters, 1 as one FimmTrackBank, 2 as that bank through the sensor file's
// covariance calibration; range(2) = linearizations per update (1: EKF, 5: IEKF). Items: track
// steps.
void BM_FimmMultiTrack(benchmark::State& state) {
  const auto tracks = static_cast<std::size_t>(state.range(0));
  const bool bank_api = state.range(1) >= 1;
  static const imm::datasets::Track track = imm::bench::preset_track("fimm_table1", 1);
  const auto sensor = std::make_shared<const imm::TskSensorModel>(
      imm::io::read_tsk_sensor(IMM_SOURCE_DIR "/models/tsk_range_sensor.h5"));
  imm::FimmSpec spec;
  spec.sample_period = imm::bench::preset_sample_period("fimm_table1");
  spec.measurement_covariance = track.noise.covariance();
  spec.iterations = static_cast<int>(state.range(2));
  const Eigen::Vector2d offset(0.001, 0.02);
  auto start = [&](std::size_t t) {
    imm::GaussianState<6> s;
    s.mean = track.truth.row(0).transpose();
    s.mean(0) += offset.x() * static_cast<double>(t);
    s.mean(3) += offset.y() * static_cast<double>(t);
    s.covariance.setIdentity();
    return s;
  };
  const auto make_filter = [&] { return std::make_unique<imm::FimmFilter>(spec, sensor); };
  if (state.range(1) == 2) {
    step_tracks(state, tracks,
                calibrated(std::make_unique<imm::TrackBankAdapter<imm::FimmTrackBank>>(spec, sensor,
                                                                                       tracks),
                           IMM_SOURCE_DIR "/models/tsk_range_sensor.h5"),
                make_filter, track.plots, offset, start);
  } else {
    step_tracks(state, tracks,
                bank_api ? std::make_unique<imm::FimmTrackBank>(spec, sensor, tracks) : nullptr,
                make_filter, track.plots, offset, start);
  }
  state.SetLabel(std::string(bank_api ? "FimmTrackBank" : "separate filters") +
                 (spec.iterations == 1 ? ", EKF" : ", IEKF ≤ 5") +
                 (state.range(1) == 2 ? ", calibrated" : ""));
}
BENCHMARK(BM_FimmMultiTrack)
    ->Args({1000, 0, 1})
    ->Args({1000, 1, 1})
    ->Args({1000, 2, 1})
    ->Args({1000, 0, 5})
    ->Args({1000, 1, 5});

// N tracks of seed 003's FCM-IMM with the shipped fit (models/fcm_imm.h5) on the seed-003 zigzag
// plots, shifted by (37, −21) m per track: range(1) = 0 as N one-track filters
// (make_fcm_imm_filter), 1 as one FcmImmTrackBank; range(2) = 1 with constant memberships (the
// ablation: no clustering). Items: track steps.
void BM_FcmImmMultiTrack(benchmark::State& state) {
  const auto tracks = static_cast<std::size_t>(state.range(0));
  const bool bank_api = state.range(1) == 1;
  auto spec = imm::io::read_fcm_imm(IMM_SOURCE_DIR "/models/fcm_imm.h5");
  spec.constant_memberships = state.range(2) == 1;
  static const Eigen::MatrixXd source = imm::bench::preset_track("fcm_imm_zigzag").plots;
  const Eigen::Vector2d offset(37.0, -21.0);
  auto start = [&](std::size_t t) {
    imm::GaussianState<4> s;
    s.mean << source(0, 0) + offset.x() * static_cast<double>(t), 0.0,
        source(0, 1) + offset.y() * static_cast<double>(t), 0.0;
    s.covariance = Eigen::Vector4d(1e4, 2e4, 1e4, 2e4).asDiagonal();
    return s;
  };
  step_tracks(
      state, tracks, bank_api ? std::make_unique<imm::FcmImmTrackBank>(spec, tracks) : nullptr,
      [&] { return imm::make_fcm_imm_filter(spec); }, source, offset, start);
  state.SetLabel(std::string(bank_api ? "FcmImmTrackBank" : "separate filters") +
                 (spec.constant_memberships ? ", constant memberships" : ", fitted"));
}
BENCHMARK(BM_FcmImmMultiTrack)
    ->Args({1000, 0, 0})
    ->Args({1000, 1, 0})
    ->Args({1000, 0, 1})
    ->Args({1000, 1, 1});

}  // namespace
