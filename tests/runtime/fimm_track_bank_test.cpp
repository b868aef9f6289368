// SPDX-License-Identifier: Apache-2.0
// The FIMM's bank against the one-track FimmFilter: statuses, estimates and μ to rounding through
// a nonlinear TSK sensor (EKF and iterated EKF), the identity and the shipped sensors, tracks
// independent of their neighbours to the bit, refused plots leaving a track exactly as it was,
// and what it refuses.
#include "imm/tracking/fimm_track_bank.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "imm/calibrated_track_bank.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/load.hpp"
#include "testing/axis_lane_bank_checks.hpp"
#include "testing/regimes.hpp"
#include "testing/tsk_sensors.hpp"

namespace imm {
namespace {

// The test sensor (testing/tsk_sensors.hpp; saturating, so that the iterated EKF relinearizes);
// the cut-in's first scans lie outside its box (η < 1).
std::shared_ptr<const TskSensorModel> shared_sensor_like_model(
    TNorm t_norm, OutsideBox outside = OutsideBox::kLinear) {
  return std::make_shared<const TskSensorModel>(testing::sensor_like_model(t_norm, outside));
}

// Track t's plots: test track t of the cut-in regime (two lane changes, 200 scans of 0.1 s), a
// NaN or an out-of-range plot now and then.
struct Plots {
  std::vector<Eigen::MatrixXd> tracks;
  std::vector<GaussianState<6>> starts;
};

Plots cut_in_plots(int tracks) {
  Plots out;
  for (int t = 0; t < tracks; ++t) {
    const datasets::Track data = testing::test_track(testing::cut_in_regime(0.5), 7, t);
    Eigen::MatrixXd z = data.plots;
    for (Eigen::Index k = 0; k < z.rows(); ++k) {
      if ((k + t) % 29 == 3) z(k, 1) = std::numeric_limits<double>::quiet_NaN();
      if ((k * 7 + t) % 53 == 11) z(k, 0) = 1e300;
    }
    out.tracks.push_back(z);
    GaussianState<6> start;
    start.mean = data.truth.row(0).transpose();
    start.mean(0) += 0.3;
    start.covariance = Vector<6>(1.0, 1.0, 1.0, 4.0, 4.0, 1.0).asDiagonal();
    start.covariance(0, 1) = start.covariance(1, 0) = 0.2;
    out.starts.push_back(start);
  }
  return out;
}

// Track t's estimate and μ against its one-track filter's, to `tolerance` of each entry's scale.
void expect_close(const FimmTrackBank& bank, std::size_t t, const FimmFilter& filter,
                  const std::string& at, double tolerance) {
  const GaussianState<6>& reference = filter.estimate();
  testing::expect_estimate_close(bank.estimate(t), reference.mean, reference.covariance,
                                 bank.mode_probabilities(t), filter.mode_probabilities(), at,
                                 tolerance);
}

// Every track of the bank beside its own one-track filter, scan by scan up to `last_scan`, to
// `tolerance` of each entry's scale; returns the refusals.
int expect_equals_one_track_filters(const FimmSpec& spec,
                                    const std::shared_ptr<const TskSensorModel>& sensor,
                                    const Plots& data, const std::string& name,
                                    Eigen::Index last_scan = 199, double tolerance = 1e-12) {
  const std::size_t tracks = data.tracks.size();
  FimmTrackBank bank(spec, sensor, tracks);
  auto single = testing::one_track_filters(
      tracks, [&] { return std::make_unique<FimmFilter>(spec, sensor); });
  const auto last = static_cast<int>(std::min(last_scan, data.tracks[0].rows() - 1));
  return testing::follow_one_track_filters(
      bank, single, name, 1, last, [&](int t) { return data.starts[static_cast<std::size_t>(t)]; },
      [&](int t, int k) -> Eigen::Vector2d {
        return data.tracks[static_cast<std::size_t>(t)].row(k).transpose();
      },
      [&](std::size_t t, const std::string& at) {
        expect_close(bank, t, *single[t], at, tolerance);
      });
}

TEST(FimmTrackBank, EqualsTheOneTrackFilterToRounding) {
  const Plots data = cut_in_plots(11);
  int refused = 0;
  for (const int iterations : {1, 3, 8}) {
    for (const TNorm t_norm : {TNorm::kProduct, TNorm::kMin}) {
      for (const OutsideBox outside : {OutsideBox::kLinear, OutsideBox::kHold}) {
        FimmSpec spec;
        spec.sample_period = 0.1;
        spec.measurement_covariance << 0.25, 0.05, 0.05, 0.3;
        spec.iterations = iterations;
        spec.transition << 0.95, 0.05, 0.1, 0.9;
        refused += expect_equals_one_track_filters(
            spec, shared_sensor_like_model(t_norm, outside), data,
            "iterations " + std::to_string(iterations) + ", " + std::string(to_string(t_norm)) +
                (outside == OutsideBox::kLinear ? ", linear outside" : ", held outside"));
        if (HasFailure()) return;
      }
    }
  }
  FimmSpec spec;
  spec.sample_period = 0.1;
  spec.measurement_covariance = 0.25 * Eigen::Matrix2d::Identity();
  refused += expect_equals_one_track_filters(spec, nullptr, data, "identity");
  EXPECT_GT(refused, 100);  // the NaN and out-of-range plots were refused, by both
}

// The bank's mode step is the one-track filter's (fimm_step.hpp), so they differ only by the
// rounding of the IMM cycle around it (the bank's mixing and posterior by lane_exp and lane_log):
// below 1e-13 of an entry's scale on the test sensor (1e-12 above). With the shipped sensors the
// lane changes swing μ and that rounding grows to a few 1e-11 with GCC, 3.2e-9 under Clang's
// sanitizer build (scan 163): 1e-8 here. The hard sensor's tracks also leave its trained box in
// their last scans, where the outside-box continuation has a kink and the one-track filter itself
// moves by up to 7e-8 of an entry's scale when its start is perturbed by 1e-15 (track 6, scan
// 196): its comparison ends at scan 150.
TEST(FimmTrackBank, EqualsTheOneTrackFilterWithTheShippedSensors) {
  const Plots data = cut_in_plots(9);
  for (const char* name : {"tsk_range_sensor.h5", "tsk_range_sensor_hard.h5"}) {
    const io::ModelFileReader reader(std::string("models/") + name);
    const auto sensor = std::make_shared<const TskSensorModel>(io::read_tsk_sensor(reader));
    const std::optional<FimmSpec> spec = io::read_fimm_settings(reader);
    ASSERT_TRUE(spec.has_value()) << name;
    const Eigen::Index last = std::string(name) == "tsk_range_sensor.h5" ? 199 : 150;
    expect_equals_one_track_filters(*spec, sensor, data, name, last, 1e-8);
    FimmSpec iterated = *spec;
    iterated.iterations = 5;
    expect_equals_one_track_filters(iterated, sensor, data, std::string(name) + " iterated", last,
                                    1e-8);
  }
}

// The gating matrix of tracks followed to scan `last` beside their one-track filters equals the
// filters' candidate questions after predict() to `tolerance` of an entry's scale (the bank
// follows the filter to rounding, see above), and asking changes no track.
void expect_gating_as_the_one_track_filters(const FimmSpec& spec,
                                            const std::shared_ptr<const TskSensorModel>& sensor,
                                            const Plots& data, const std::string& name, int last,
                                            double tolerance) {
  const std::size_t tracks = data.tracks.size();
  FimmTrackBank bank(spec, sensor, tracks);
  auto single = testing::one_track_filters(
      tracks, [&] { return std::make_unique<FimmFilter>(spec, sensor); });
  testing::expect_gating_without_changing_a_track(
      bank, single, name, 1, last, [&](int t) { return data.starts[static_cast<std::size_t>(t)]; },
      [&](int t, int k) -> Eigen::Vector2d {
        return data.tracks[static_cast<std::size_t>(t)].row(k).transpose();
      },
      [&](std::size_t t, const std::string& at) {
        expect_close(bank, t, *single[t], at, tolerance);
      },
      tolerance, 2);
}

TEST(FimmTrackBank, ScoresCandidatePlotsAsTheOneTrackFilterWithoutChangingATrack) {
  const Plots data = cut_in_plots(11);
  for (const int iterations : {1, 3}) {
    FimmSpec spec;
    spec.sample_period = 0.1;
    spec.measurement_covariance << 0.25, 0.05, 0.05, 0.3;
    spec.iterations = iterations;
    spec.transition << 0.95, 0.05, 0.1, 0.9;
    expect_gating_as_the_one_track_filters(spec, shared_sensor_like_model(TNorm::kProduct), data,
                                           "iterations " + std::to_string(iterations), 120, 1e-11);
    if (HasFailure()) return;
  }
  FimmSpec spec;
  spec.sample_period = 0.1;
  spec.measurement_covariance = 0.25 * Eigen::Matrix2d::Identity();
  expect_gating_as_the_one_track_filters(spec, nullptr, data, "identity", 120, 1e-11);
  const io::ModelFileReader reader("models/tsk_range_sensor.h5");
  const std::optional<FimmSpec> shipped = io::read_fimm_settings(reader);
  ASSERT_TRUE(shipped.has_value());
  expect_gating_as_the_one_track_filters(
      *shipped, std::make_shared<const TskSensorModel>(io::read_tsk_sensor(reader)), data,
      "tsk_range_sensor.h5", 120, 1e-8);
}

TEST(FimmTrackBank, ATracksResultDoesNotDependOnItsNeighboursToTheBit) {
  const Plots data = cut_in_plots(11);
  FimmSpec spec;
  spec.sample_period = 0.1;
  spec.iterations = 4;
  const auto sensor = shared_sensor_like_model(TNorm::kProduct);
  testing::expect_tracks_independent_of_their_neighbours(
      11, 80, [&](std::size_t n) { return FimmTrackBank(spec, sensor, n); },
      [&](int t) { return data.starts[static_cast<std::size_t>(t)]; },
      [&](int t, int k) {
        return Eigen::Vector2d(data.tracks[static_cast<std::size_t>(t)].row(k + 1));
      },
      testing::expect_same_mu<FimmTrackBank>);
}

TEST(FimmTrackBank, ARefusedPlotLeavesTheTrackExactlyAsItWas) {
  const Plots data = cut_in_plots(5);
  FimmSpec spec;
  spec.sample_period = 0.1;
  spec.iterations = 3;
  FimmTrackBank bank(spec, shared_sensor_like_model(TNorm::kMin), 5);
  for (std::size_t t = 0; t < 5; ++t) bank.initialize(t, data.starts[t]);
  std::vector<Eigen::Vector2d> plots(3);
  std::vector<StepStatus> status(3);
  for (Eigen::Index k = 1; k <= 10; ++k) {
    for (std::size_t t = 0; t < 3; ++t) plots[t] = data.tracks[t].row(k);
    bank.step(plots, status);
  }
  plots[0] = data.tracks[0].row(11);
  plots[1].x() = std::numeric_limits<double>::infinity();
  testing::expect_refused_plot_keeps_the_track(bank, plots, 4,
                                               testing::expect_same_mu<FimmTrackBank>);
}

// A start whose prediction overflows (variances near the largest double): S is not finite, so
// the bank's lane and the one-track filter both refuse the step as a singular innovation, and
// keep the start.
TEST(FimmTrackBank, AnOverflowingPredictionIsASingularInnovationInBoth) {
  FimmSpec spec;
  spec.sample_period = 0.1;
  spec.measurement_covariance = 0.25 * Eigen::Matrix2d::Identity();
  GaussianState<6> start;
  start.mean << 1.0, 0.0, 0.0, 2.0, 0.0, 0.0;
  start.covariance = 1.79e308 * SquareMatrix<6>::Identity();
  for (const bool sensor : {false, true}) {
    const auto model = sensor ? shared_sensor_like_model(TNorm::kProduct) : nullptr;
    FimmTrackBank bank(spec, model, 1);
    bank.initialize(0, start);
    FimmFilter single(spec, model);
    single.initialize(start.mean, start.covariance);
    std::vector<StepStatus> status(1);
    const std::vector<Eigen::Vector2d> plots = {Eigen::Vector2d(1.0, 2.0)};
    bank.step(plots, status);
    EXPECT_EQ(status[0], StepStatus::kSingularInnovation) << sensor;
    EXPECT_EQ(single.step(plots[0]), StepStatus::kSingularInnovation) << sensor;
    EXPECT_EQ(bank.estimate(0).mean, start.mean) << sensor;
    EXPECT_EQ(single.estimate().mean, start.mean) << sensor;
  }
}

// The shipped FIMM's file carries a covariance calibration: open_track_bank wraps its bank in a
// CalibratedTrackBank, which follows the calibrated one-track filters load_filter builds. The NIS
// the bank states each step is the filter's last_step_nis (the modes' innovations of the update
// collapsed with c_j), to the rounding by which the bank follows the filter (1e-8 with this
// sensor, above), so the features, the factors and the calibrated gate are the filter's.
TEST(FimmTrackBank, OpenedFromTheShippedFileItIsCalibratedAsItsFilters) {
  const std::string path = "models/tsk_range_sensor.h5";
  const Plots data = cut_in_plots(9);
  const std::size_t tracks = data.tracks.size();
  auto bank = open_track_bank(path, tracks);
  ASSERT_NE(bank->calibration(), nullptr);
  auto& calibrated = dynamic_cast<CalibratedTrackBank&>(*bank);
  auto single = testing::one_track_filters(tracks, [&] { return load_filter(path).filter; });
  for (std::size_t t = 0; t < tracks; ++t) {
    bank->initialize(t, data.starts[t].mean, data.starts[t].covariance);
    single[t]->initialize(data.starts[t].mean, data.starts[t].covariance);
  }
  std::vector<Eigen::Vector2d> plots(tracks);
  std::vector<StepStatus> status(tracks);
  std::vector<double> nis(tracks);
  for (int k = 1; k <= 120; ++k) {
    for (std::size_t t = 0; t < tracks; ++t) plots[t] = data.tracks[t].row(k).transpose();
    // The NIS the wrapped bank states, as the one-track filter's own (unscaled) NIS.
    calibrated.step(plots, status, nis);
    for (std::size_t t = 0; t < tracks; ++t) {
      const std::string at = "scan " + std::to_string(k) + " track " + std::to_string(t);
      ASSERT_EQ(status[t], single[t]->step(plots[t])) << at;
      const auto& filter = dynamic_cast<const CalibratedFilter&>(*single[t]);
      if (status[t] == StepStatus::kOk) {
        const auto reference = last_step_nis(filter.inner());
        ASSERT_TRUE(reference.has_value()) << at;
        EXPECT_NEAR(nis[t], *reference, 1e-7 * *reference) << at;
      } else {
        EXPECT_TRUE(std::isnan(nis[t])) << at;
      }
      EXPECT_EQ(calibrated.plots_used(t), filter.plots_used()) << at;
      EXPECT_NEAR(calibrated.nis_level(t), filter.nis_level(), 1e-7 * filter.nis_level()) << at;
      EXPECT_EQ(calibrated.state_scale(t), filter.state_scale()) << at;
      Eigen::VectorXd mean, variance(6);
      Eigen::MatrixXd covariance, reference(6, 6);
      bank->estimate(t, mean, covariance);
      single[t]->covariance(reference);
      for (int a = 0; a < 6; ++a) {
        for (int c = 0; c < 6; ++c) {
          const double scale = std::sqrt(std::abs(reference(a, a) * reference(c, c)));
          EXPECT_NEAR(covariance(a, c), reference(a, c), 1e-8 * scale) << at;
        }
      }
    }
    if (HasFailure()) return;
  }
  // The calibrated gate: each track's next plot and plots along its first axis at 0.99 and 1.01
  // of the calibrated filter's gate distance, found by bisection.
  for (std::size_t t = 0; t < tracks; ++t) ASSERT_EQ(single[t]->predict(), StepStatus::kOk);
  constexpr double kGate = 9.21;
  for (std::size_t t = 0; t < tracks; ++t) {
    Eigen::Vector2d z_hat;
    Eigen::Matrix2d S;
    ASSERT_TRUE(single[t]->predicted_plot(z_hat, S));
    const Eigen::Vector2d direction(std::sqrt(S(0, 0)), 0.0);
    std::vector<Eigen::Vector2d> candidates;
    for (const double factor : {0.99, 1.01}) {
      double low = 0.0, high = 100.0;
      for (int i = 0; i < 80; ++i) {
        const double mid = 0.5 * (low + high);
        (single[t]->candidate_distance(z_hat + mid * direction) > factor * kGate ? high : low) =
            mid;
      }
      candidates.emplace_back(z_hat + low * direction);
    }
    Eigen::MatrixXd out(static_cast<Eigen::Index>(tracks), 2);
    bank->candidate_log_likelihoods(candidates, kGate, out);
    const auto row = static_cast<Eigen::Index>(t);
    EXPECT_TRUE(std::isfinite(out(row, 0))) << t;
    EXPECT_EQ(out(row, 1), -std::numeric_limits<double>::infinity()) << t;
    EXPECT_NEAR(out(row, 0), single[t]->candidate_log_likelihood(candidates[0]),
                1e-8 * std::abs(out(row, 0)))
        << t;
  }
}

TEST(FimmTrackBank, RefusesWhatItCannotRun) {
  FimmSpec spec;
  spec.sample_period = 0.1;
  EXPECT_EQ(testing::refused_field<FimmTrackBank>(spec, nullptr, 0), "capacity");
  spec.transition << 1.0, 0.0, 0.03, 0.97;  // cruise absorbing
  EXPECT_EQ(testing::refused_field<FimmTrackBank>(spec, nullptr, 4), "transition");
  spec = FimmSpec();
  spec.sample_period = 0.1;
  spec.iterations = 0;
  EXPECT_EQ(testing::refused_field<FimmTrackBank>(spec, nullptr, 4), "iterations");
  spec = FimmSpec();
  spec.sample_period = 0.1;
  FimmTrackBank bank(spec, nullptr, 3);
  GaussianState<6> bad;
  bad.mean.setZero();
  bad.covariance.setIdentity();
  bad.covariance(2, 2) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(testing::refused_field_of([&] { bank.initialize(0, bad); }), "initial_covariance");
  bad.covariance(2, 2) = 1.0;
  testing::expect_refused_misuse(bank, bad, Eigen::Vector2d(3.0, 1.0));
  testing::expect_refused_gating(bank);
}

}  // namespace
}  // namespace imm
