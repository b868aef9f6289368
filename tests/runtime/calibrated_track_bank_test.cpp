// SPDX-License-Identifier: Apache-2.0
// CalibratedTrackBank: a bank opened from a calibrated model follows the calibrated one-track
// filters load_filter builds — the same features (plots used, NIS level), covariances scaled alike,
// and a gating matrix whose gate is the calibrated distance's, judged at 0.99 and 1.01 of the
// gate — on the shipped plain IMMs (the general bank, Cartesian and polar plots), on the shipped
// input estimators, GA-fuzzy IMMs, FCM-IMMs and nIMMs (their lane banks; the FIMM's in
// fimm_track_bank_test.cpp), and on TrackBank's vectorized kernel under a calibration of many bins
// set by hand; the NIS each bank states equals last_step_nis of its filter, the fusing wIMM's
// too; and what it refuses.
#include "imm/calibrated_track_bank.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "imm/core/invalid_parameter.hpp"
#include "imm/load.hpp"
#include "imm/math/chi_square.hpp"
#include "imm/tracking/track_bank.hpp"
#include "testing/axis_lane_bank_checks.hpp"
#include "testing/refused_field.hpp"
#include "testing/specs.hpp"

namespace imm {
namespace {

// A start: a mean and a covariance of the filter's dimension.
struct Start {
  Eigen::VectorXd mean;
  Eigen::MatrixXd covariance;
};

// The calls of an AnyTrackBank in the shape the bank checks use.
struct BankView {
  AnyTrackBank& bank;
  void initialize(std::size_t t, const Start& s) { bank.initialize(t, s.mean, s.covariance); }
  void step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status) {
    bank.step(plots, status);
  }
  void candidate_log_likelihoods(std::span<const Eigen::Vector2d> plots, double gate,
                                 Eigen::Ref<Eigen::MatrixXd> out) {  // NOLINT: a view
    bank.candidate_log_likelihoods(plots, gate, out);
  }
};

// The target of track t at scan k, metres: 200 m/s, a 3 °/s turn over scans 15–25, from a start
// of its own. `period` the scan's seconds.
Eigen::Vector2d position(int t, int k, double period) {
  const double speed = 200.0 * period;  // per scan
  Eigen::Vector2d p(20e3 + 3e3 * t, 10e3 - 2e3 * t);
  double heading = 0.3 * t;
  for (int i = 0; i < k; ++i) {
    if (i >= 15 && i < 25) heading += 3.0 * M_PI / 180.0 * period;
    p += speed * Eigen::Vector2d(std::cos(heading), std::sin(heading));
  }
  return p;
}

// The state layout of a plain IMM of n states (plain_imm.hpp): y's index.
int y_index(int n) { return n == 4 || n == 5 ? 2 : 3; }

Start start_of(int t, int n, double period) {
  Start s{Eigen::VectorXd::Zero(n), Eigen::MatrixXd::Zero(n, n)};
  const Eigen::Vector2d p = position(t, 0, period);
  const int y = y_index(n);
  s.mean(0) = p.x();
  s.mean(y) = p.y();
  s.mean(1) = 200.0 * std::cos(0.3 * t);
  s.mean(y + 1) = 200.0 * std::sin(0.3 * t);
  s.covariance.diagonal().setConstant(1.0);
  s.covariance(0, 0) = s.covariance(y, y) = 2500.0;
  s.covariance(1, 1) = s.covariance(y + 1, y + 1) = 1e4;
  if (n == 5 || n == 7) s.covariance(n - 1, n - 1) = 1e-3;
  return s;
}

// Track t's plot at scan k: 40 m noise (Cartesian) or 40 m and 2 mrad (polar); track 1's plot is
// unusable every 7th scan and track 2's 3 km off every 9th (a NIS far above the level's bins).
Eigen::Vector2d plot_of(int t, int k, double period, bool polar, std::mt19937_64& rng) {
  std::normal_distribution<double> unit(0.0, 1.0);
  Eigen::Vector2d p = position(t, k, period);
  if (t == 2 && k % 9 == 0) p += Eigen::Vector2d(3e3, -1e3);
  if (t == 1 && k % 7 == 0) return {std::nan(""), 0.0};
  if (!polar) return p + 40.0 * Eigen::Vector2d(unit(rng), unit(rng));
  return {p.norm() + 40.0 * unit(rng), std::atan2(p.y(), p.x()) + 2e-3 * unit(rng)};
}

// A bank and its calibrated one-track filters (CalibratedFilter), stepped alike: the same
// statuses, NIS and features, the estimate and scaled covariance to `tolerance`, then the gating
// matrix at the calibrated gate and three scans more.
void expect_bank_follows_calibrated_filters(AnyTrackBank& bank,
                                            std::vector<std::unique_ptr<TrackFilter>>& single,
                                            double period, bool polar, double tolerance,
                                            const std::string& name) {
  auto& calibrated = dynamic_cast<CalibratedTrackBank&>(bank);
  const int n = bank.state_dimension();
  std::mt19937_64 rng(11);
  const auto plot = [&](int t, int k) { return plot_of(t, k, period, polar, rng); };
  const auto compare = [&](std::size_t t, const std::string& at) {
    const auto& filter = dynamic_cast<const CalibratedFilter&>(*single[t]);
    EXPECT_EQ(calibrated.plots_used(t), filter.plots_used()) << at;
    EXPECT_NEAR(calibrated.nis_level(t), filter.nis_level(), 1e-9 * filter.nis_level()) << at;
    EXPECT_EQ(calibrated.state_scale(t), filter.state_scale()) << at;
    Eigen::VectorXd mean(n), variance(n);
    Eigen::MatrixXd covariance(n, n), reference(n, n);
    single[t]->state(mean, variance);
    single[t]->covariance(reference);
    Eigen::VectorXd bank_mean;
    bank.estimate(t, bank_mean, covariance);
    for (int a = 0; a < n; ++a) {
      EXPECT_NEAR(bank_mean(a), mean(a), tolerance * (1.0 + std::abs(mean(a)))) << at;
      for (int c = 0; c < n; ++c) {
        const double scale = std::sqrt((1.0 + reference(a, a)) * (1.0 + reference(c, c)));
        EXPECT_NEAR(covariance(a, c), reference(a, c), tolerance * scale) << at << " " << a << c;
      }
    }
  };
  BankView view{bank};
  testing::expect_gating_without_changing_a_track(
      view, single, name, 1, 40, [&](int t) { return start_of(t, n, period); }, plot, compare,
      tolerance, 3);
  // The features moved: the level left 2 and the start table's last entry holds on.
  for (std::size_t t = 0; t < single.size(); ++t) {
    EXPECT_GT(calibrated.plots_used(t), 30) << name;
    EXPECT_NE(calibrated.nis_level(t), 2.0) << name;
  }
}

std::vector<std::unique_ptr<TrackFilter>> calibrated_filters(const std::string& path,
                                                             std::size_t n) {
  return testing::one_track_filters(n, [&] { return load_filter(path).filter; });
}

// A shipped model, the plots its scene takes, and how closely its bank follows its filter.
struct Shipped {
  const char* model;
  bool polar;
  double tolerance;
};

// Opens `m`'s bank of `tracks` tracks and its calibrated filters, and steps them side by side.
void expect_shipped_bank_follows_its_filters(const Shipped& m, std::size_t tracks) {
  const std::string path = std::string("models/") + m.model + ".h5";
  const double period = load_filter(path).options.sample_period;
  auto single = calibrated_filters(path, tracks);
  auto bank = open_track_bank(path, tracks);
  ASSERT_NE(bank->calibration(), nullptr) << m.model;
  ASSERT_NE(dynamic_cast<CalibratedTrackBank*>(bank.get()), nullptr) << m.model;
  expect_bank_follows_calibrated_filters(*bank, single, period, m.polar, m.tolerance, m.model);
}

TEST(CalibratedTrackBank, OpenedFromTheShippedPlainImmsItGatesAndStatesAsTheirFilters) {
  // The general bank is the one-track IMM itself: the same numbers.
  for (const Shipped& m : {Shipped{"classical_imm_agile_air", false, 0.0},
                           Shipped{"classical_imm_ground_vehicle", false, 0.0},
                           Shipped{"classical_imm_air_surveillance", true, 0.0}}) {
    expect_shipped_bank_follows_its_filters(m, 5);
  }
}

TEST(CalibratedTrackBank, OpenedFromTheShippedLearnedModelsItGatesAndStatesAsTheirFilters) {
  // 11 tracks: a block of 8 (16 axis lanes) and three more. The input estimator's bank runs its
  // one-track filter's scan per lane: the same numbers. The GA-fuzzy IMM's, the FCM-IMM's and the
  // nIMM's (the wIMM without fusion, polar plots) follow their filters to rounding (lane
  // exponentials, the mixing's order): the NIS each step states is the modes' innovations of the
  // update collapsed as ImmEstimator::innovation does, so the features, the factors and the gate
  // are the filters'. The scene is an aircraft's (200 m/s, 40 m plots): the air regimes' models
  // (the FIMM's, of a road scene, in fimm_track_bank_test.cpp).
  for (const Shipped& m :
       {Shipped{"mlp_input_estimator_agile_air", false, 0.0},
        Shipped{"mlp_input_estimator_ground_vehicle", false, 0.0},
        Shipped{"mlp_input_estimator", false, 0.0}, Shipped{"ga_fuzzy_imm_agile_air", false, 1e-9},
        Shipped{"ga_fuzzy_imm_agile_air_recorded", false, 1e-9},
        Shipped{"fcm_imm_agile_air", false, 1e-9},
        Shipped{"fcm_imm_agile_air_recorded", false, 1e-9},
        Shipped{"baseline_nimm_air_surveillance", true, 1e-9},
        Shipped{"wimm_air_surveillance", true, 1e-9}}) {
    expect_shipped_bank_follows_its_filters(m, 11);
  }
}

// A calibration of five start entries and four level bins with factors far from 1, so that a track
// crosses bins and each factor shows.
std::shared_ptr<CovarianceCalibration> many_bins() {
  auto c = std::make_shared<CovarianceCalibration>();
  c->memory = 0.6;
  c->nis_cap = 30.0;
  c->start_innovation = {2.5, 1.8, 1.3, 1.1, 0.9};
  c->start_state = {3.0, 2.0, 1.5, 1.2, 0.8};
  c->edges = {1.0, 2.0, 4.0};
  c->level_innovation = {0.6, 0.9, 1.4, 2.2};
  c->level_state = {0.5, 0.8, 1.6, 3.0};
  return c;
}

TEST(CalibratedTrackBank, OnTrackBanksKernelItGatesAndStatesAsTheCalibratedFilters) {
  // Three CV modes with Cartesian plots: TrackBank's vectorized kernel, 11 tracks (a whole block
  // of 8 and three left over).
  std::vector<ModeSpec> modes;
  for (const double q : {0.5, 20.0, 400.0}) {
    modes.push_back(
        testing::mode_spec("q" + std::to_string(modes.size()), MotionKind::kConstantVelocity, q));
  }
  Eigen::Matrix2d R;
  R << 1600.0, 100.0, 100.0, 1500.0;
  const PlainImmSpec spec =
      testing::switching_spec(std::move(modes), 1.0, 0.05, MeasurementKind::kCartesian, R);
  const auto calibration = many_bins();
  auto single = testing::one_track_filters(11, [&] {
    return std::unique_ptr<TrackFilter>(
        std::make_unique<CalibratedFilter>(make_plain_imm_filter(spec), calibration));
  });
  CalibratedTrackBank bank(std::make_unique<TrackBankAdapter<TrackBank>>(spec, 11), calibration);
  expect_bank_follows_calibrated_filters(bank, single, 1.0, false, 1e-9, "TrackBank");
}

class TheNisABankStates : public ::testing::TestWithParam<const char*> {
 protected:
  // The same arithmetic where the bank's state is the filter's bits; to rounding where its mode
  // probabilities take lane exponentials (the GA-fuzzy IMM) or its modes' steps are written over
  // lanes of tracks (the wIMM).
  static double tolerance() {
    const std::string model = GetParam();
    if (model.starts_with("ga_fuzzy")) return 1e-12;
    return model.starts_with("wimm") ? 1e-9 : 0.0;
  }
};

TEST_P(TheNisABankStates, IsItsFiltersLastStepNis) {
  const std::string path = std::string("models/") + GetParam() + ".h5";
  const TrackOptions options = load_filter(path).options;
  const double period = options.sample_period;
  const bool polar = options.measurement_kind == MeasurementKind::kPolar;
  auto bank = open_track_bank(path, 3);
  auto& inner = dynamic_cast<CalibratedTrackBank&>(*bank).inner();
  ASSERT_TRUE(inner.states_step_nis());
  auto single = testing::one_track_filters(3, [&] { return load_filter(path).filter; });
  const int n = bank->state_dimension();
  for (std::size_t t = 0; t < 3; ++t) {
    const Start s = start_of(static_cast<int>(t), n, period);
    inner.initialize(t, s.mean, s.covariance);
    single[t]->initialize(s.mean, s.covariance);
  }
  std::mt19937_64 rng(3);
  std::vector<Eigen::Vector2d> plots(3);
  std::vector<StepStatus> status(3);
  std::vector<double> nis(3);
  for (int k = 1; k <= 20; ++k) {
    for (int t = 0; t < 3; ++t)
      plots[static_cast<std::size_t>(t)] = plot_of(t, k, period, polar, rng);
    inner.step(plots, status, nis);
    for (std::size_t t = 0; t < 3; ++t) {
      ASSERT_EQ(status[t], single[t]->step(plots[t]));
      // The model's own NIS: the calibrated filter's inner one (its own innovation() is scaled).
      const auto reference = last_step_nis(dynamic_cast<CalibratedFilter&>(*single[t]).inner());
      if (status[t] != StepStatus::kOk) {
        EXPECT_TRUE(std::isnan(nis[t])) << k;
      } else {
        ASSERT_TRUE(reference.has_value());
        EXPECT_NEAR(nis[t], *reference, tolerance() * *reference) << k << " " << t;
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Banks, TheNisABankStates,
                         ::testing::Values("classical_imm_agile_air",
                                           "mlp_input_estimator_agile_air",
                                           "ga_fuzzy_imm_agile_air", "fcm_imm_agile_air", "wimm",
                                           "wimm_air_surveillance"));

// A bank of one track that states no NIS: AnyTrackBank's required calls only.
class SilentBank final : public AnyTrackBank {
 public:
  using AnyTrackBank::step;
  [[nodiscard]] std::size_t capacity() const override { return 1; }
  [[nodiscard]] int state_dimension() const override { return 4; }
  void initialize(std::size_t /*track*/, const Eigen::VectorXd& /*mean*/,
                  const Eigen::MatrixXd& /*covariance*/) override {}
  void step(std::span<const Eigen::Vector2d> /*plots*/, std::span<StepStatus> status) override {
    std::fill(status.begin(), status.end(), StepStatus::kOk);
  }
  [[nodiscard]] bool initialized(std::size_t /*track*/) const override { return true; }
  void estimate(std::size_t /*track*/, Eigen::VectorXd& mean,
                Eigen::MatrixXd& covariance) const override {
    mean = Eigen::VectorXd::Zero(4);
    covariance = Eigen::MatrixXd::Identity(4, 4);
  }
  [[nodiscard]] ModeVector mode_probabilities(std::size_t /*track*/) const override {
    return ModeVector::Ones(1);
  }
};

TEST(CalibratedTrackBank, RefusesWhatItCannotCalibrateAndNamesTheField) {
  const auto calibration = many_bins();
  EXPECT_EQ(testing::refused_field_of([&] { CalibratedTrackBank bank(nullptr, calibration); }),
            "bank");
  // A bank that states no NIS (every bank of this runtime does; a kind registered elsewhere need
  // not) cannot be calibrated.
  auto silent = std::make_unique<SilentBank>();
  EXPECT_FALSE(silent->states_step_nis());
  EXPECT_EQ(
      testing::refused_field_of([&] { CalibratedTrackBank bank(std::move(silent), calibration); }),
      "bank");
  EXPECT_EQ(testing::refused_field_of([&] {
              CalibratedTrackBank bank(open_track_bank("models/cv3_imm.h5", 2), nullptr);
            }),
            "calibration");
  auto broken = std::make_shared<CovarianceCalibration>(*calibration);
  broken->level_state.pop_back();
  EXPECT_EQ(testing::refused_field_of(
                [&] { CalibratedTrackBank bank(open_track_bank("models/cv3_imm.h5", 2), broken); }),
            "calibration.level_state");
  // A file without a calibration opens the bank itself.
  EXPECT_EQ(open_track_bank("models/cv3_imm.h5", 2)->calibration(), nullptr);

  // Per-track gates: one positive factor per asked track.
  CalibratedTrackBank bank(open_track_bank("models/cv3_imm.h5", 3), calibration);
  bank.initialize(0, Eigen::Vector4d::Zero(), Eigen::Matrix4d::Identity());
  const std::vector<Eigen::Vector2d> plots(2, Eigen::Vector2d(0.1, 0.2));
  Eigen::MatrixXd one(1, 2);
  const std::vector<double> two_factors{1.0, 1.0}, negative{-1.0}, nan{std::nan("")};
  EXPECT_EQ(testing::refused_field_of(
                [&] { bank.candidate_log_likelihoods(plots, 9.0, two_factors, one); }),
            "gate_scale");
  EXPECT_EQ(
      testing::refused_field_of([&] { bank.candidate_log_likelihoods(plots, 9.0, negative, one); }),
      "gate_scale[0]");
  EXPECT_EQ(
      testing::refused_field_of([&] { bank.candidate_log_likelihoods(plots, 9.0, nan, one); }),
      "gate_scale[0]");
  const std::vector<Eigen::Vector2d> first(1, Eigen::Vector2d(0.1, 0.2));
  std::vector<double> two(2);
  std::vector<StepStatus> status(1);
  EXPECT_THROW(bank.step(first, status, two), std::invalid_argument);
  EXPECT_THROW((void)bank.plots_used(3), std::out_of_range);
  BankView view{bank};
  testing::expect_refused_gating(view);
}

}  // namespace
}  // namespace imm
