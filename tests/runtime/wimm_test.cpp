// SPDX-License-Identifier: Apache-2.0
#include "imm/filters/wimm.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "imm/core/invalid_parameter.hpp"
#include "imm/io/wimm_file.hpp"
#include "imm/tracking/tracker.hpp"
#include "testing/matrix_checks.hpp"
#include "testing/regimes.hpp"
#include "testing/temp_dir.hpp"

namespace imm {
namespace {

TEST(BlendAngles, StaysOnTheRightSideOfTheSouthSeam) {
  // Plot just east of south (π − 0.01), prediction just west of south (−π + 0.01): the blend is
  // due south, not north.
  const double fused = blend_angles(std::numbers::pi - 0.01, -std::numbers::pi + 0.01, 0.5);
  EXPECT_NEAR(std::abs(fused), std::numbers::pi, 1e-12);
  EXPECT_NEAR(blend_angles(0.3, 0.1, 0.5), 0.2, 1e-15);
  EXPECT_NEAR(blend_angles(0.3, 0.1, 1.0), 0.3, 1e-15);
  EXPECT_NEAR(blend_angles(std::numbers::pi - 0.01, -std::numbers::pi + 0.03, 0.25),
              -std::numbers::pi + 0.02, 1e-12);
}

// Runs a filter over one run of a scenario through the tracker; returns the 6-state estimates.
std::vector<Vector<6>> track(const WimmSpec& spec, const datasets::Track& data,
                             std::vector<bool>* fused = nullptr) {
  Tracker tracker(std::make_unique<WimmFilter>(spec), spec.track_options());
  std::vector<Vector<6>> estimates;
  Eigen::VectorXd mean(6), variance(6);
  const Eigen::MatrixXd& z = data.plots;
  for (Eigen::Index k = 0; k < z.rows(); ++k) {
    (void)tracker.process(k, z.row(k).transpose());
    if (!tracker.initialized()) continue;
    tracker.state(mean, variance);
    estimates.emplace_back(mean);
    if (fused != nullptr) {
      fused->push_back(static_cast<const WimmFilter&>(tracker.filter()).fused());
    }
  }
  return estimates;
}

datasets::Track scenario_run(int number, std::uint64_t seed = 3) {
  return testing::test_track(testing::wimm_table2_regime(number), seed);
}

WimmSpec with_fusion(FusionVariant fusion) {
  WimmSpec spec;
  spec.sample_period = 2.0;
  spec.fusion = fusion;
  return spec;
}

// μ̄_CV never exceeds 1: the threshold 1 never fuses.
TEST(Wimm, ThresholdOneIsExactlyTheNormalImm) {
  const auto data = scenario_run(2);
  WimmSpec never = with_fusion(FusionVariant::kSeed);
  never.threshold = 1.0;
  const auto a = track(with_fusion(FusionVariant::kNone), data);
  const auto b = track(never, data);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) ASSERT_EQ(a[k], b[k]) << "scan " << k;
}

TEST(Wimm, AlphaOneIsTheNormalImm) {
  const auto data = scenario_run(1);
  WimmSpec plot_only = with_fusion(FusionVariant::kSeed);
  plot_only.alpha = 1.0;
  std::vector<bool> fused;
  const auto a = track(with_fusion(FusionVariant::kNone), data);
  const auto b = track(plot_only, data, &fused);
  EXPECT_GT(std::count(fused.begin(), fused.end(), true), 200);  // the fusion path did run
  for (std::size_t k = 0; k < a.size(); ++k) {
    ASSERT_TRUE(testing::matrices_near(b[k], a[k], 1e-9)) << "scan " << k;
  }
}

// The derivation: with the fused plot's correlation to the prediction modelled, the update is the
// normal IMM's (to rounding), for both modes and the mode probabilities.
TEST(Wimm, CorrelatedFusionEqualsTheNormalImm) {
  for (int number : {1, 2}) {
    const auto data = scenario_run(number);
    std::vector<bool> fused;
    const auto a = track(with_fusion(FusionVariant::kNone), data);
    const auto b = track(with_fusion(FusionVariant::kCorrelated), data, &fused);
    EXPECT_GT(std::count(fused.begin(), fused.end(), true), 150);
    for (std::size_t k = 0; k < a.size(); ++k) {
      ASSERT_TRUE(testing::matrices_near(b[k], a[k], 1e-8))
          << "scenario " << number << " scan " << k;
    }
  }
}

// Per scan with an update: the plot's log predictive density and NIS, and whether the cycle fused.
struct PlotTerms {
  std::vector<double> density, nis;
  std::vector<bool> fused;
};

PlotTerms plot_terms(const WimmSpec& spec, const datasets::Track& data) {
  Tracker tracker(std::make_unique<WimmFilter>(spec), spec.track_options());
  PlotTerms terms;
  const Eigen::MatrixXd& z = data.plots;
  for (Eigen::Index k = 0; k < z.rows(); ++k) {
    const TrackStepResult result = tracker.process(k, z.row(k).transpose());
    if (result.event != TrackEvent::kUpdated) continue;
    const auto& filter = static_cast<const WimmFilter&>(tracker.filter());
    terms.density.push_back(filter.log_predictive_likelihood());
    terms.nis.push_back(last_step_nis(filter).value_or(-1.0));
    terms.fused.push_back(filter.fused());
  }
  return terms;
}

// The correlated fusion updates exactly as the normal IMM, so it predicts the same plots: its
// density and NIS of the plot (not of the fused azimuth) are the normal IMM's at every scan.
TEST(WimmPlotDensity, TheCorrelatedFusionPredictsThePlotsAsTheNormalImm) {
  const auto data = scenario_run(1);
  const PlotTerms normal = plot_terms(with_fusion(FusionVariant::kNone), data);
  const PlotTerms fused = plot_terms(with_fusion(FusionVariant::kCorrelated), data);
  ASSERT_EQ(normal.density.size(), fused.density.size());
  EXPECT_GT(std::count(fused.fused.begin(), fused.fused.end(), true), 150);
  for (std::size_t k = 0; k < normal.density.size(); ++k) {
    ASSERT_NEAR(fused.density[k], normal.density[k], 1e-7) << "scan " << k;
    ASSERT_NEAR(fused.nis[k], normal.nis[k], 1e-6 * (1.0 + normal.nis[k])) << "scan " << k;
  }
}

// Up to the first fused cycle the seed's fusion has not acted, so its prediction of that cycle's
// plot is the normal IMM's: the plot's density and NIS agree there, for either update (the fused
// azimuth, 0.3 of the way from the prediction to the plot, would give another density).
TEST(WimmPlotDensity, AtTheFirstFusedCycleThePlotIsPredictedAsByTheNormalImm) {
  const auto data = scenario_run(1);
  for (const MeasurementUpdate update :
       {MeasurementUpdate::kExtended, MeasurementUpdate::kConverted}) {
    WimmSpec seed = with_fusion(FusionVariant::kSeed);
    WimmSpec normal = with_fusion(FusionVariant::kNone);
    seed.update = normal.update = update;
    seed.alpha = 0.3;
    const PlotTerms a = plot_terms(normal, data);
    const PlotTerms b = plot_terms(seed, data);
    const auto first =
        static_cast<std::size_t>(std::find(b.fused.begin(), b.fused.end(), true) - b.fused.begin());
    ASSERT_LT(first, b.fused.size());
    for (std::size_t k = 0; k <= first; ++k) {
      ASSERT_NEAR(b.density[k], a.density[k], 1e-9) << to_string(update) << " scan " << k;
      ASSERT_NEAR(b.nis[k], a.nis[k], 1e-9 * (1.0 + a.nis[k]))
          << to_string(update) << " scan " << k;
    }
    EXPECT_GT(std::abs(b.density[first + 1] - a.density[first + 1]), 1e-9)
        << "the fusion acted after the first fused cycle";
  }
}

// The seed's fusion does change the estimate, and on a constant-velocity target it fuses nearly
// all the time once settled.
TEST(Wimm, SeedFusionActsOnConstantVelocity) {
  const auto data = scenario_run(1);
  std::vector<bool> fused;
  const auto a = track(with_fusion(FusionVariant::kNone), data);
  const auto b = track(with_fusion(FusionVariant::kSeed), data, &fused);
  EXPECT_GT(std::count(fused.begin() + 40, fused.end(), true), 190);
  EXPECT_FALSE(testing::matrices_near(b.back(), a.back(), 1e-6));
}

// A target crossing the negative y axis (azimuth through ±π): the fused azimuth must follow it.
TEST(Wimm, FusionAcrossTheSouthSeamTracksTheTarget) {
  datasets::Regime s = testing::scripted_regime(2.0, 200, {20e3, -50e3}, {-200.0, 0.0});
  s.sensor.kind = datasets::SensorKind::kPolar;
  s.sensor.noise.sigma = Eigen::Vector2d(50.0, 0.5 * std::numbers::pi / 180.0);
  const datasets::Track data = testing::test_track(s, 1);
  std::vector<bool> fused;
  const auto estimates = track(with_fusion(FusionVariant::kSeed), data, &fused);
  EXPECT_TRUE(fused[45] && fused[50] && fused[55]);  // fusing while the target crosses (scan ~50)
  const Eigen::MatrixXd& truth = data.truth;
  double worst = 0.0;
  for (std::size_t i = 20; i < estimates.size(); ++i) {
    const auto k = static_cast<Eigen::Index>(i + 1);  // first estimate at scan 1
    const double error = wrap_angle(azimuth_of(estimates[i](0), estimates[i](3)) -
                                    azimuth_of(truth(k, 0), truth(k, 3)));
    worst = std::max(worst, std::abs(error));
  }
  EXPECT_LT(worst, 0.05);  // a few σ_θ; a seam error would be ~π
}

TEST(WimmFile, RoundTrip) {
  const testing::TempDir dir;
  WimmSpec spec;
  spec.sample_period = 2.0;
  spec.threshold = 0.83;
  spec.alpha = 0.41;
  spec.fusion = FusionVariant::kCorrelated;
  spec.transition << 0.9, 0.1, 0.2, 0.8;
  {
    io::Provenance provenance;
    provenance.model_kind = std::string(io::kWimmKind);
    io::ModelFileWriter writer(dir / "w.h5", provenance);
    io::write_wimm(writer, spec);
    writer.commit();
  }
  const WimmSpec back = io::read_wimm(dir / "w.h5");
  EXPECT_EQ(back.threshold, 0.83);
  EXPECT_EQ(back.alpha, 0.41);
  EXPECT_EQ(back.fusion, FusionVariant::kCorrelated);
  EXPECT_EQ(back.transition, spec.transition);
  EXPECT_EQ(back.azimuth_sigma, spec.azimuth_sigma);
  EXPECT_EQ(back.update, MeasurementUpdate::kExtended);
}

TEST(WimmSpec, ValidationNamesTheField) {
  WimmSpec spec;
  spec.sample_period = 2.0;
  spec.alpha = 0.0;
  EXPECT_THROW(spec.validate(), std::invalid_argument);
  spec = WimmSpec{};
  spec.sample_period = 2.0;
  spec.fusion = FusionVariant::kCorrelated;
  spec.update = MeasurementUpdate::kConverted;
  try {
    spec.validate();
    FAIL();
  } catch (const InvalidParameter& error) {
    EXPECT_EQ(error.field(), "fusion");
  }
}

}  // namespace
}  // namespace imm
