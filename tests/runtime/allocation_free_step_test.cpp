// SPDX-License-Identifier: Apache-2.0
// Proves that a filter step does not touch the heap: this test binary replaces the global
// operator new/delete with counting versions, runs the filters past their set-up, and requires
// zero allocations over many steps (plain KF, IMM with mixed dimensions, polar EKF modes).

#include <gtest/gtest.h>

// The replacement operators below pair malloc/free deliberately.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

#include <atomic>
#include <cstdlib>
#include <memory>
#include <new>

#include "imm/calibrated_track_bank.hpp"
#include "imm/estimation/imm_estimator.hpp"
#include "imm/estimation/kalman_mode.hpp"
#include "imm/filters/aimm.hpp"
#include "imm/filters/fcm_imm.hpp"
#include "imm/filters/fimm.hpp"
#include "imm/filters/ga_fuzzy_imm.hpp"
#include "imm/filters/mlp_input_estimator.hpp"
#include "imm/filters/plain_imm.hpp"
#include "imm/filters/wimm.hpp"
#include "imm/models/measurement/polar_measurement.hpp"
#include "imm/models/measurement/position_measurement.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/models/motion/singer.hpp"
#include "imm/tracking/fcm_imm_track_bank.hpp"
#include "imm/tracking/fimm_track_bank.hpp"
#include "imm/tracking/ga_fuzzy_track_bank.hpp"
#include "imm/tracking/input_estimator_track_bank.hpp"
#include "imm/tracking/plain_imm_track_bank.hpp"
#include "imm/tracking/track_bank.hpp"
#include "imm/tracking/tracker.hpp"
#include "imm/tracking/wimm_track_bank.hpp"
#include "testing/specs.hpp"

namespace {
std::atomic<long> g_allocations{0};
}

void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) { return operator new(size); }
void* operator new(std::size_t size, std::align_val_t alignment) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  const auto align = static_cast<std::size_t>(alignment);
  if (void* p = std::aligned_alloc(align, (size + align - 1) / align * align)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size, std::align_val_t alignment) {
  return operator new(size, alignment);
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace imm {
namespace {

long allocations() { return g_allocations.load(std::memory_order_relaxed); }

TEST(AllocationFreeStep, CountingAllocatorSeesAllocations) {
  const long before = allocations();
  auto probe = std::make_unique<int>(3);
  EXPECT_GT(allocations(), before);  // the counter is live, so zero below means something
}

TEST(AllocationFreeStep, KalmanPredictAndUpdate) {
  const auto model = constant_velocity<2>(1.0, 1e-4);
  const PositionMeasurement<4, 2> measurement({0, 2}, 0.25 * SquareMatrix<2>::Identity());
  GaussianState<4> state;
  const long before = allocations();
  for (int k = 0; k < 10000; ++k) {
    state = predict(state, model.transition, model.process_noise);
    (void)update(state, Vector<2>(0.1 * k, 0.0), measurement);
  }
  EXPECT_EQ(allocations(), before);
}

TEST(AllocationFreeStep, PlainCvImmStep) {
  const PlainImmSpec spec = testing::cv3_spec();
  auto imm = build_plain_imm<4>(spec);
  imm.initialize(GaussianState<4>{});
  const long before = allocations();
  for (int k = 0; k < 10000; ++k) {
    (void)imm.step(Vector<2>(0.01 * k, -0.02 * k));
    if (k % 100 == 0) (void)imm.predict_only();
    (void)imm.mode_probabilities();
  }
  (void)imm.step(Vector<2>(std::nan(""), 0.0));
  EXPECT_EQ(allocations(), before);
}

// A Tracker's cycle with its envelope test (a window's NIS into a fixed ring) allocates nothing
// either, flags and rejected plots included.
TEST(AllocationFreeStep, TrackerCycleWithItsEnvelopeTest) {
  const PlainImmSpec spec = testing::cv3_spec();
  TrackOptions options = spec.track_options(kDefaultMaxGap);
  options.envelope = {20, 0.01};
  Tracker tracker(make_plain_imm_filter(spec), options);
  (void)tracker.process(0, Eigen::Vector2d(0.0, 0.0));
  (void)tracker.process(1, Eigen::Vector2d(1.0, 0.5));
  const long before = allocations();
  bool flagged = false;
  for (int k = 2; k < 5000; ++k) {
    const double jump = k > 4000 ? 5.0 * (k - 4000) : 0.0;  // plots the model does not expect
    const TrackStepResult r = tracker.process(k, Eigen::Vector2d(1.0 * k + jump, 0.5 * k));
    flagged = flagged || r.outside_envelope;
  }
  (void)tracker.process(5000, Eigen::Vector2d(std::nan(""), 0.0));
  EXPECT_EQ(allocations(), before);
  EXPECT_TRUE(flagged);
}

// The multi-track API: 1000 tracks (several blocks and a partial one), bad plots included.
TEST(AllocationFreeStep, TrackBankStep) {
  const std::size_t tracks = 1000;
  TrackBank bank(testing::cv3_spec(), tracks);
  for (std::size_t t = 0; t < tracks; ++t) bank.initialize(t, GaussianState<4>{});
  std::vector<Eigen::Vector2d> plots(tracks);
  std::vector<StepStatus> status(tracks);
  const long before = allocations();
  for (int k = 0; k < 200; ++k) {
    for (std::size_t t = 0; t < tracks; ++t)
      plots[t] = Eigen::Vector2d(0.01 * k + static_cast<double>(t), -0.02 * k);
    plots[7] = Eigen::Vector2d(std::nan(""), 0.0);
    bank.step(plots, status);
    (void)bank.mode_probabilities(3);
  }
  EXPECT_EQ(status[7], StepStatus::kInvalidMeasurement);
  EXPECT_EQ(status[8], StepStatus::kOk);
  EXPECT_EQ(allocations(), before);
}

// Tracks in the banks' allocation tests: whole blocks and a partial one.
constexpr std::size_t kBankTracks = 1001;

// 100 steps of every track of `bank` (each started at `start`; track t at (dx k + t, dy k), track
// 7 a NaN plot) allocate nothing; the bad plot is refused and the last track stepped.
template <class Bank, class State = GaussianState<4>>
void expect_bank_steps_allocate_nothing(Bank& bank, double dx, double dy, const State& start = {}) {
  for (std::size_t t = 0; t < kBankTracks; ++t) bank.initialize(t, start);
  std::vector<Eigen::Vector2d> plots(kBankTracks);
  std::vector<StepStatus> status(kBankTracks);
  const long before = allocations();
  for (int k = 0; k < 100; ++k) {
    for (std::size_t t = 0; t < kBankTracks; ++t)
      plots[t] = Eigen::Vector2d(dx * k + static_cast<double>(t), dy * k);
    plots[7] = Eigen::Vector2d(std::nan(""), 0.0);
    bank.step(plots, status);
  }
  EXPECT_EQ(status[7], StepStatus::kInvalidMeasurement);
  EXPECT_EQ(status[kBankTracks - 1], StepStatus::kOk);
  EXPECT_EQ(allocations(), before);
}

// The bank of any plain IMM, here CV + CA + CT modes in 7 states: kBankTracks tracks, bad plots
// included; reading a track's log μ allocates nothing either.
TEST(AllocationFreeStep, PlainImmTrackBankStep) {
  PlainImmSpec spec = testing::cv3_spec();
  spec.modes[1].motion = MotionKind::kConstantAcceleration;
  spec.modes[2].motion = MotionKind::kCoordinatedTurn;
  spec.modes[2].turn_noise = 1e-4;
  spec.initialization.turn_rate_variance = 0.01;
  ASSERT_EQ(spec.mixing_dimension(), 7);
  PlainImmTrackBank<7> bank(spec, kBankTracks);
  GaussianState<7> start;
  start.mean.setZero();
  start.covariance = SquareMatrix<7>::Identity();
  expect_bank_steps_allocate_nothing(bank, 0.5, -0.2, start);
  const long before = allocations();
  (void)bank.log_mode_probabilities(3);
  EXPECT_EQ(allocations(), before);
}

// A calibrated bank (CalibratedTrackBank) over TrackBank's kernel, over the general bank of a
// shipped calibrated CV/CA/CT IMM and over the lane banks of a shipped input estimator, GA-fuzzy
// IMM, FCM-IMM, nIMM and FIMM: its steps
// (features from the NIS each states) and its gating matrix with a gate per track, bad plots
// included.
TEST(AllocationFreeStep, CalibratedTrackBankStepAndGating) {
  auto calibration = std::make_shared<CovarianceCalibration>();
  calibration->start_innovation = {2.0, 1.0};
  calibration->start_state = {3.0, 1.0};
  calibration->edges = {1.0, 3.0};
  calibration->level_innovation = {0.8, 1.0, 1.5};
  calibration->level_state = {0.7, 1.0, 2.0};
  std::vector<std::unique_ptr<AnyTrackBank>> banks;
  banks.push_back(std::make_unique<CalibratedTrackBank>(
      std::make_unique<TrackBankAdapter<TrackBank>>(testing::cv3_spec(), kBankTracks),
      calibration));
  banks.push_back(open_track_bank("models/classical_imm_agile_air.h5", kBankTracks));
  for (const char* model : {"mlp_input_estimator_agile_air", "ga_fuzzy_imm_agile_air",
                            "fcm_imm_agile_air", "tsk_range_sensor", "wimm_air_surveillance"}) {
    banks.push_back(open_track_bank(std::string("models/") + model + ".h5", kBankTracks));
  }
  for (std::size_t b = 0; b < banks.size(); ++b) {
    AnyTrackBank* bank = banks[b].get();
    ASSERT_NE(bank->calibration(), nullptr);
    // The last, the nIMM, takes polar plots (range, azimuth from north) of a target 28 km out.
    const bool polar = b + 1 == banks.size();
    const int n = bank->state_dimension();
    Eigen::VectorXd start = Eigen::VectorXd::Zero(n);
    if (polar) start(0) = start(3) = 2e4;  // [x, vx, ax, y, vy, ay]
    for (std::size_t t = 0; t < kBankTracks; ++t) {
      bank->initialize(t, start, 1e4 * Eigen::MatrixXd::Identity(n, n));
    }
    std::vector<Eigen::Vector2d> plots(kBankTracks);
    std::vector<StepStatus> status(kBankTracks);
    Eigen::MatrixXd scores(static_cast<Eigen::Index>(kBankTracks), 4);
    std::vector<Eigen::Vector2d> candidates{{1.0, 0.0}, {0.0, 1.0}, {50.0, -3.0}, {0.0, 0.0}};
    if (polar) candidates = {{28284.0, 0.785}, {28000.0, 0.8}, {5e4, -3.0}, {28300.0, 0.78}};
    const long before = allocations();
    for (int k = 0; k < 50; ++k) {
      for (std::size_t t = 0; t < kBankTracks; ++t) {
        plots[t] =
            polar ? Eigen::Vector2d(28284.27 + 0.5 * k + static_cast<double>(t), 0.7854 + 1e-4 * k)
                  : Eigen::Vector2d(0.5 * k + static_cast<double>(t), -0.2 * k);
      }
      plots[7] = Eigen::Vector2d(std::nan(""), 0.0);
      bank->step(plots, status);
      bank->candidate_log_likelihoods(candidates, 9.21, scores);
    }
    EXPECT_EQ(allocations(), before);
    EXPECT_EQ(status[7], StepStatus::kInvalidMeasurement);
    EXPECT_EQ(status[kBankTracks - 1], StepStatus::kOk);
  }
}

// The GA-fuzzy IMM's bank: kBankTracks tracks, bad plots
// included.
TEST(AllocationFreeStep, GaFuzzyTrackBankStep) {
  GaFuzzyImmSpec spec;
  spec.settings.sample_period = 1.0;
  spec.levels = {
      {"u0.001", 0.001, FuzzyRuleTable({{0.0, 1.0, 0.0, 1.0, 4e-6}, {1.0, 0.5, 0.5, 2.0, 2e-6}})},
      {"u0.1", 0.1, FuzzyRuleTable({{0.0, 1.0, 0.0, 1.0, 1e-2}})}};
  GaFuzzyTrackBank bank(spec, kBankTracks);
  expect_bank_steps_allocate_nothing(bank, 0.01, -0.02);
}

// Fed times at irregular intervals, a CV/CA/CT IMM remakes every mode's F and Q and its mode
// transitions each cycle without allocating.
TEST(AllocationFreeStep, TrackerCycleAtIrregularTimes) {
  PlainImmSpec spec = testing::cv3_spec();
  Tracker tracker(make_plain_imm_filter(spec), spec.track_options(kDefaultMaxGap));
  ASSERT_TRUE(tracker.filter().takes_any_interval());
  (void)tracker.process_at(0.0, Eigen::Vector2d(0.0, 0.0));
  (void)tracker.process_at(1.0, Eigen::Vector2d(1.0, 0.5));
  const long before = allocations();
  double t = 1.0;
  int updated = 0;
  for (int k = 2; k < 2000; ++k) {
    t += 0.25 + 0.5 * (k % 5);
    const TrackStepResult r = tracker.process_at(t, Eigen::Vector2d(1.0 * t, 0.5 * t));
    updated += r.event == TrackEvent::kUpdated ? 1 : 0;
  }
  EXPECT_EQ(allocations(), before);
  EXPECT_EQ(updated, 1998);
}

TEST(AllocationFreeStep, MixedDimensionPolarImmStep) {
  SquareMatrix<2> R;
  R << 50.0 * 50.0, 0.0, 0.0, std::pow(0.5 * 3.14159265358979 / 180.0, 2);
  std::vector<std::unique_ptr<ImmMode<6, 2>>> modes;
  modes.push_back(std::make_unique<KalmanMode<6, 4, PolarMeasurement<4>>>(
      "cv", constant_velocity<2>(2.0, 2.0), PolarMeasurement<4>(0, 2, R),
      StateEmbedding<4, 6>(std::array<int, 4>{0, 1, 3, 4})));
  modes.push_back(std::make_unique<KalmanMode<6, 6, PolarMeasurement<6>>>(
      "singer", singer<2>(2.0, 20.0, 5.0), PolarMeasurement<6>(0, 3, R), StateEmbedding<6, 6>()));
  Eigen::Matrix2d pi;
  pi << 0.95, 0.05, 0.05, 0.95;
  ImmEstimator<6, 2> imm(std::move(modes), pi, Eigen::Vector2d(0.5, 0.5));
  GaussianState<6> start;
  start.mean << 1e5, -100.0, 0.0, 1e5, -100.0, 0.0;
  start.covariance = Eigen::Matrix<double, 6, 1>(2500, 100, 1, 2500, 100, 1).asDiagonal();
  imm.initialize(start);
  const long before = allocations();
  for (int k = 1; k <= 5000; ++k) {
    const double x = 1e5 - 200.0 * k, y = 1e5 - 200.0 * k + 5e5;
    (void)imm.step(Vector<2>(std::hypot(x, y), std::atan2(x, y)));
  }
  EXPECT_EQ(allocations(), before);
}

// The seed-000 filters (GA-fuzzy IMM and AIMM, two axes each), seed 003's FCM-IMM and seed 004's
// weighted IMM.
TEST(AllocationFreeStep, GaFuzzyImmAndAimmSteps) {
  GaFuzzyImmSpec fuzzy;
  fuzzy.settings.sample_period = 1.0;
  fuzzy.levels = {
      {"u0.001", 0.001, FuzzyRuleTable({{0.0, 1.0, 0.0, 1.0, 4e-6}, {1.0, 0.5, 0.5, 2.0, 2e-6}})},
      {"u0.01", 0.01, FuzzyRuleTable({{0.0, 1.0, 0.0, 1.0, 1.2e-4}})},
      {"u0.1", 0.1, FuzzyRuleTable({{0.0, 1.0, 0.0, 1.0, 1e-2}})}};
  AimmSpec aimm;
  aimm.settings.sample_period = 1.0;
  aimm.intervals = {0.02, 0.04};
  std::vector<std::unique_ptr<TrackFilter>> filters;
  filters.push_back(make_ga_fuzzy_imm_filter(fuzzy));
  filters.push_back(make_aimm_filter(aimm));
  for (auto scale : {MembershipScale::kSeed, MembershipScale::kInnovation}) {
    FcmImmSpec fcm;  // seed 003's FCM-IMM, with both membership scales
    fcm.sample_period = 1.0;
    fcm.scale = scale;
    fcm.measurement_sigma = 0.3;
    fcm.clustering.fuzzifier = 2.5;
    filters.push_back(make_fcm_imm_filter(fcm));
  }
  for (auto fusion : {FusionVariant::kSeed, FusionVariant::kCorrelated}) {
    WimmSpec wimm;
    wimm.sample_period = 2.0;
    wimm.fusion = fusion;
    wimm.range_sigma = 0.05;  // km-scale plots of this loop
    wimm.azimuth_sigma = 0.01;
    filters.push_back(std::make_unique<WimmFilter>(wimm));
  }
  for (auto& filter : filters) {
    const int n = filter->state_dimension();
    const Eigen::VectorXd mean = Eigen::VectorXd::Constant(n, 10.0);
    const Eigen::MatrixXd covariance = Eigen::MatrixXd::Identity(n, n);
    filter->initialize(mean, covariance);
    const long before = allocations();
    for (int k = 1; k <= 5000; ++k) {
      (void)filter->step(Eigen::Vector2d(10.0 + 0.1 * k + 0.3 * std::sin(k), 3.0 + 0.01 * k));
      if (k % 50 == 0) (void)filter->predict_only();
    }
    EXPECT_EQ(allocations(), before);
  }
}

// A 2-10-1 input estimator with constant weights.
MlpInputEstimatorModel small_input_estimator() {
  MlpInputEstimatorModel model;
  MlpLayer hidden{Eigen::MatrixXd::Constant(10, 2, 0.1), Eigen::VectorXd::Constant(10, 0.1),
                  Activation::kSigmoid};
  MlpLayer output{Eigen::MatrixXd::Constant(1, 10, 0.2), Eigen::VectorXd::Constant(1, -1.0),
                  Activation::kSigmoid};
  model.network = Mlp({hidden, output}, 12.0);
  model.settings.sample_period = 1.0;
  return model;
}

TEST(AllocationFreeStep, MlpInputEstimatorStep) {
  const MlpInputEstimatorModel model = small_input_estimator();
  MlpInputEstimatorFilter filter(model, model.settings);
  GaussianState<2> start;
  start.mean << 0.0, 100.0;
  start.covariance << 2500.0, 2500.0, 2500.0, 5000.0;
  filter.initialize(start);
  const long before = allocations();
  for (int k = 1; k <= 5000; ++k) (void)filter.step(100.0 * k + 20.0 * std::sin(k));
  EXPECT_EQ(allocations(), before);
}

// The input estimator's bank: kBankTracks tracks, bad plots
// included.
TEST(AllocationFreeStep, InputEstimatorTrackBankStep) {
  InputEstimatorTrackBank bank(small_input_estimator(), kBankTracks);
  expect_bank_steps_allocate_nothing(bank, 100.0, -20.0);
}

// The weighted IMM's bank (seed fusion on every scan, a converted update beside it): kBankTracks
// tracks, a bad plot included.
TEST(AllocationFreeStep, WimmTrackBankStep) {
  for (const MeasurementUpdate update :
       {MeasurementUpdate::kExtended, MeasurementUpdate::kConverted}) {
    WimmSpec spec;
    spec.sample_period = 2.0;
    spec.threshold = 0.0;
    spec.update = update;
    WimmTrackBank bank(spec, kBankTracks);
    GaussianState<6> start;
    start.mean << 3e4, -100.0, 0.0, 6e4, 50.0, 0.0;
    start.covariance = Eigen::Matrix<double, 6, 1>(2500, 100, 1, 2500, 100, 1).asDiagonal();
    for (std::size_t t = 0; t < kBankTracks; ++t) bank.initialize(t, start);
    std::vector<Eigen::Vector2d> plots(kBankTracks);
    std::vector<StepStatus> status(kBankTracks);
    const long before = allocations();
    for (int k = 1; k <= 100; ++k) {
      for (std::size_t t = 0; t < kBankTracks; ++t) {
        const double x = 3e4 - 200.0 * k + static_cast<double>(t), y = 6e4 + 100.0 * k;
        plots[t] = Eigen::Vector2d(std::hypot(x, y), std::atan2(x, y));
      }
      plots[7] = Eigen::Vector2d(std::nan(""), 0.0);
      bank.step(plots, status);
    }
    EXPECT_EQ(status[7], StepStatus::kInvalidMeasurement);
    EXPECT_EQ(status[kBankTracks - 1], StepStatus::kOk);
    EXPECT_TRUE(bank.fused(kBankTracks - 1));
    EXPECT_EQ(allocations(), before);
  }
}

TEST(AllocationFreeStep, FimmStepThroughTheTskSensor) {
  // Seed 002's FIMM with a three-rule TSK sensor, as EKF and as iterated EKF, also across the
  // trained box's edge (the outside-box continuation).
  std::array<TskOutput, 2> outputs;
  for (int i = 0; i < 2; ++i) {
    for (int r = 0; r < 3; ++r) {
      TskRule rule;
      rule.center << -2.0 + 2.0 * r, 15.0 + 30.0 * r;
      rule.width << 3.0, 15.0;
      rule.consequent << 0.1 * r, i == 0 ? 0.9 : 0.01, i == 0 ? 0.002 : 0.9 - 0.2 * r;
      outputs[static_cast<std::size_t>(i)].rules.push_back(rule);
    }
    outputs[static_cast<std::size_t>(i)].sigma = 0.05;
  }
  const auto sensor = std::make_shared<const TskSensorModel>(
      outputs, TNorm::kMin, Eigen::Vector2d(-6.0, 1.0), Eigen::Vector2d(6.0, 100.0));
  for (int iterations : {1, 5}) {
    FimmSpec spec;
    spec.sample_period = 0.1;
    spec.iterations = iterations;
    FimmFilter filter(spec, sensor);
    Eigen::VectorXd start = Eigen::VectorXd::Zero(6);
    start(0) = 3.5;
    start(4) = 3.0;
    filter.initialize(start, Eigen::MatrixXd::Identity(6, 6));
    const long before = allocations();
    for (int k = 1; k <= 5000; ++k) {
      const double eta = 0.03 * k;  // 0 … 150 m: leaves the box at both ends
      (void)filter.step(Eigen::Vector2d(3.5 * std::cos(0.01 * k), 40.0 * std::tanh(eta / 40.0)));
      if (k % 50 == 0) (void)filter.predict_only();
    }
    EXPECT_EQ(allocations(), before) << iterations;

    // Its bank: kBankTracks tracks, a bad plot included.
    FimmTrackBank bank(spec, sensor, kBankTracks);
    GaussianState<6> state;
    state.mean = start;
    state.covariance.setIdentity();
    for (std::size_t t = 0; t < kBankTracks; ++t) bank.initialize(t, state);
    std::vector<Eigen::Vector2d> plots(kBankTracks);
    std::vector<StepStatus> status(kBankTracks);
    const long bank_before = allocations();
    for (int k = 1; k <= 100; ++k) {
      for (std::size_t t = 0; t < kBankTracks; ++t) {
        plots[t] =
            Eigen::Vector2d(3.5 * std::cos(0.01 * k), 0.3 * k + 1e-3 * static_cast<double>(t));
      }
      plots[7] = Eigen::Vector2d(std::nan(""), 0.0);
      bank.step(plots, status);
    }
    EXPECT_EQ(status[7], StepStatus::kInvalidMeasurement);
    EXPECT_EQ(status[kBankTracks - 1], StepStatus::kOk);
    EXPECT_EQ(allocations(), bank_before) << iterations;
  }
}

// The FCM-IMM's bank: kBankTracks tracks, bad plots included (the clustering's windows are the
// bank's own slots and scratch).
TEST(AllocationFreeStep, FcmImmTrackBankStep) {
  FcmImmSpec fcm;
  fcm.sample_period = 1.0;
  FcmImmTrackBank bank(fcm, kBankTracks);
  expect_bank_steps_allocate_nothing(bank, 100.0, -20.0);
}

}  // namespace
}  // namespace imm
