// SPDX-License-Identifier: Apache-2.0
// imm-train tsk: the FCRM membership update (hand values, the I_q case), FCRM recovering known
// hyperplanes, the parameter gradient of the fine tuning against finite differences, fine tuning
// beating FCRM on held-out data, thread-count independence, config errors and a small training
// run end to end.

#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>

#include "imm/datasets/random.hpp"
#include "imm/datasets/track.hpp"
#include "imm/io/model_file.hpp"
#include "imm/io/tsk_sensor_file.hpp"
#include "imm/support/config.hpp"
#include "imm/trainer/tsk/tsk_fit.hpp"
#include "imm/trainer/tsk/tsk_trainer.hpp"
#include "testing/config_error.hpp"
#include "testing/temp_dir.hpp"

namespace imm::trainer::tsk {
namespace {

// --- FCRM -------------------------------------------------------------------------------------

TEST(FcrmMemberships, HandComputed) {
  // d = (1, 2, 4), m = 2: μ ∝ 1/d² = (1, 1/4, 1/16) → (16, 4, 1)/21.
  const Eigen::VectorXd u = fcrm_memberships(Eigen::Vector3d(1.0, 2.0, 4.0), 2.0);
  EXPECT_NEAR(u(0), 16.0 / 21.0, 1e-15);
  EXPECT_NEAR(u(1), 4.0 / 21.0, 1e-15);
  EXPECT_NEAR(u(2), 1.0 / 21.0, 1e-15);
  // m = 3: μ ∝ 1/d = (1, 1/2, 1/4) → (4, 2, 1)/7. The seed's printed ratio d^s/d^r would give
  // the farthest hyperplane the largest membership.
  const Eigen::VectorXd v = fcrm_memberships(Eigen::Vector3d(1.0, 2.0, 4.0), 3.0);
  EXPECT_NEAR(v(0), 4.0 / 7.0, 1e-15);
  EXPECT_NEAR(v(2), 1.0 / 7.0, 1e-15);
}

TEST(FcrmMemberships, ASampleOnAHyperplaneBelongsToItAlone) {
  EXPECT_EQ(fcrm_memberships(Eigen::Vector3d(3.0, 0.0, 5.0), 2.0), Eigen::Vector3d(0, 1, 0));
  // On two hyperplanes (where they cross): shared equally, none for the third.
  EXPECT_EQ(fcrm_memberships(Eigen::Vector3d(0.0, 2.0, 0.0), 1.7), Eigen::Vector3d(0.5, 0, 0.5));
  // Tiny but non-zero distances stay finite and near the crisp answer.
  const Eigen::VectorXd u = fcrm_memberships(Eigen::Vector3d(1e-300, 1.0, 2.0), 2.0);
  EXPECT_TRUE(u.allFinite());
  EXPECT_NEAR(u(0), 1.0, 1e-15);
}

struct PlaneData {
  Eigen::MatrixXd inputs;
  Eigen::VectorXd targets;
  std::vector<int> label;
};

// Samples drawn from three known hyperplanes over the same input box, each sample from a random
// one of them (FCRM separates by the residual, not by the input).
const Eigen::Matrix3d& planes() {
  static const Eigen::Matrix3d known =
      (Eigen::Matrix3d() << 1.0, 2.0, -1.0, -3.0, 0.5, 0.5, 5.0, -1.0, 0.2).finished();
  return known;
}

PlaneData plane_data(int n, double noise, std::uint64_t seed) {
  datasets::Rng rng(seed);
  PlaneData d;
  d.inputs.resize(n, 2);
  d.targets.resize(n);
  for (int q = 0; q < n; ++q) {
    const int r = static_cast<int>(rng.below(3));
    d.inputs.row(q) << rng.uniform(-5.0, 5.0), rng.uniform(-5.0, 5.0);
    d.targets(q) = planes()(r, 0) + planes()(r, 1) * d.inputs(q, 0) +
                   planes()(r, 2) * d.inputs(q, 1) + rng.normal(0.0, noise);
    d.label.push_back(r);
  }
  return d;
}

TEST(Fcrm, RecoversThreeKnownHyperplanes) {
  const PlaneData data = plane_data(900, 0.02, 5);
  FcrmSettings settings;
  settings.restarts = 8;
  settings.tolerance = 1e-7;
  const FcrmResult result = fcrm(data.inputs, data.targets, settings, 3);
  ASSERT_EQ(result.hyperplanes.rows(), 3);
  EXPECT_TRUE(result.converged);
  // Each true plane has a recovered one within 0.02 in every coefficient; the matching is a
  // permutation.
  std::vector<int> match(3, -1);
  for (int r = 0; r < 3; ++r) {
    for (int s = 0; s < 3; ++s) {
      if ((result.hyperplanes.row(s) - planes().row(r)).cwiseAbs().maxCoeff() < 0.02) match[r] = s;
    }
    ASSERT_GE(match[r], 0) << "plane " << r << " not recovered:\n" << result.hyperplanes;
  }
  EXPECT_NE(match[0], match[1]);
  EXPECT_NE(match[1], match[2]);
  EXPECT_NE(match[0], match[2]);
  // The largest membership names the generating plane for nearly every sample (where planes
  // cross, a sample is genuinely ambiguous).
  int right = 0;
  for (Eigen::Index q = 0; q < data.inputs.rows(); ++q) {
    Eigen::Index best = 0;
    result.memberships.row(q).maxCoeff(&best);
    right += best == match[static_cast<std::size_t>(data.label[static_cast<std::size_t>(q)])];
  }
  EXPECT_GT(right, 0.95 * static_cast<double>(data.inputs.rows()));
  // Rows of U sum to 1.
  EXPECT_NEAR((result.memberships.rowwise().sum().array() - 1.0).abs().maxCoeff(), 0.0, 1e-12);
}

TEST(Fcrm, NoiseFreeDataConvergesOnTheHyperplanesWithFiniteMemberships) {
  // Without noise the samples end up (to rounding) on their hyperplanes: the I_q case is taken.
  const PlaneData data = plane_data(300, 0.0, 9);
  FcrmSettings settings;
  settings.restarts = 8;
  const FcrmResult result = fcrm(data.inputs, data.targets, settings, 4);
  EXPECT_TRUE(result.memberships.allFinite());
  EXPECT_TRUE(result.hyperplanes.allFinite());
  EXPECT_LT(result.objective, 1e-12);
}

TEST(Fcrm, ResultDoesNotDependOnTheThreadCount) {
  const PlaneData data = plane_data(600, 0.05, 21);
  FcrmSettings settings;
  settings.restarts = 6;
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const FcrmResult one = fcrm(data.inputs, data.targets, settings, 17);
  omp_set_num_threads(std::max(2, threads));
  const FcrmResult many = fcrm(data.inputs, data.targets, settings, 17);
  omp_set_num_threads(threads);
  EXPECT_EQ(one.hyperplanes, many.hyperplanes);
  EXPECT_EQ(one.objective, many.objective);
  EXPECT_EQ(one.memberships, many.memberships);
}

// --- The fine tuning ---------------------------------------------------------------------------

std::vector<TskRule> some_rules() {
  std::vector<TskRule> rules(3);
  rules[0].center << -2.0, 20.0;
  rules[0].width << 2.5, 12.0;
  rules[0].consequent << 0.3, 0.9, 0.01;
  rules[1].center << 1.0, 55.0;
  rules[1].width << 3.0, 9.0;
  rules[1].consequent << 8.0, -0.05, 0.75;
  rules[2].center << 3.0, 85.0;
  rules[2].width << 1.5, 20.0;
  rules[2].consequent << 35.0, 0.1, 0.3;
  return rules;
}

TEST(FineTuning, ParameterGradientMatchesCentralDifferences) {
  // θ per rule = (m_ξ, log s_ξ, m_η, log s_η, a₀, a_ξ, a_η).
  auto perturbed = [](std::vector<TskRule> rules, std::size_t r, int i, double delta) {
    TskRule& rule = rules[r];
    switch (i) {
      case 0:
        rule.center(0) += delta;
        break;
      case 1:
        rule.width(0) *= std::exp(delta);
        break;
      case 2:
        rule.center(1) += delta;
        break;
      case 3:
        rule.width(1) *= std::exp(delta);
        break;
      default:
        rule.consequent(i - 4) += delta;
        break;
    }
    return rules;
  };
  const std::vector<TskRule> rules = some_rules();
  for (TNorm t : {TNorm::kProduct, TNorm::kMin}) {
    for (const Eigen::Vector2d& x :
         {Eigen::Vector2d(-1.0, 30.0), Eigen::Vector2d(2.2, 61.0), Eigen::Vector2d(0.4, 90.0)}) {
      std::vector<double> gradient(21);
      const double h = output_and_parameter_gradient(rules, t, x, gradient.data());
      EXPECT_DOUBLE_EQ(h, TskSensorModel::output(rules, t, x));
      for (std::size_t r = 0; r < 3; ++r) {
        for (int i = 0; i < 7; ++i) {
          const double step = 1e-6;
          const double fd = (TskSensorModel::output(perturbed(rules, r, i, step), t, x) -
                             TskSensorModel::output(perturbed(rules, r, i, -step), t, x)) /
                            (2.0 * step);
          EXPECT_NEAR(gradient[r * 7 + static_cast<std::size_t>(i)], fd,
                      1e-6 * std::max(1.0, std::abs(fd)))
              << to_string(t) << " x " << x.transpose() << " rule " << r << " parameter " << i;
        }
      }
    }
  }
}

TEST(FineTuning, LowersTheHeldOutErrorBelowFcrmAlone) {
  datasets::Sensor sensor;
  sensor.kind = datasets::SensorKind::kRangeSensor;
  sensor.calibration.samples = 1500;
  const datasets::RangeSensorData data = datasets::draw_calibration(sensor, 12);
  const SplitData parts = split(data, 0.25, 3);
  EXPECT_EQ(parts.validation_inputs.rows(), 375);
  FcrmSettings settings;
  settings.restarts = 4;
  for (int i = 0; i < 2; ++i) {
    const Eigen::VectorXd z = parts.training_outputs.col(i);
    const Eigen::VectorXd zv = parts.validation_outputs.col(i);
    const FcrmResult clusters = fcrm(parts.training_inputs, z, settings, 8);
    std::vector<TskRule> rules = rules_from_clusters(parts.training_inputs, clusters, 2.0);
    const double before = rmse(rules, TNorm::kMin, parts.validation_inputs, zv);
    const FineTuningReport report = fine_tune(rules, TNorm::kMin, parts.training_inputs, z, {});
    const double after = rmse(rules, TNorm::kMin, parts.validation_inputs, zv);
    EXPECT_LT(report.final_cost, report.initial_cost) << i;
    EXPECT_LT(after, before) << i;
    // Down to within a small factor of the sensor's own noise (0.05 m).
    EXPECT_LT(after, 0.15) << i;
  }
}

TEST(FineTuning, AnExactModelStaysExact) {
  // Targets produced by the rules themselves: the cost starts at 0 and stays there.
  const std::vector<TskRule> truth = some_rules();
  datasets::Rng rng(2);
  Eigen::MatrixXd inputs(400, 2);
  for (Eigen::Index q = 0; q < inputs.rows(); ++q) {
    inputs.row(q) << rng.uniform(-6.0, 6.0), rng.uniform(1.0, 100.0);
  }
  const Eigen::VectorXd targets = predict(truth, TNorm::kProduct, inputs);
  std::vector<TskRule> rules = truth;
  (void)fine_tune(rules, TNorm::kProduct, inputs, targets, {});
  EXPECT_LT(rmse(rules, TNorm::kProduct, inputs, targets), 1e-9);
}

// --- Config and the trainer ------------------------------------------------------------------

std::string config_error(const std::string& text) {
  return testing::config_error_key("regime = \"configs/regimes/paper/fimm_table1.toml\"\n" + text,
                                   [](const auto& path) { return load_tsk_config(path); });
}

TEST(TskConfig, InvalidValuesAreNamed) {
  EXPECT_EQ(config_error(""), "");
  EXPECT_EQ(config_error("[fit]\nt_norm = \"max\"\n"), "fit.t_norm");
  EXPECT_EQ(config_error("[fit]\nrules = 0\n"), "fit.rules");
  EXPECT_EQ(config_error("[fit]\nfuzzifier = 1.0\n"), "fit.fuzzifier");
  EXPECT_EQ(config_error("[fit]\nrestarts = 0\n"), "fit.restarts");
  EXPECT_EQ(config_error("[fit]\nrule = 3\n"), "fit.rule");     // unknown key
  EXPECT_EQ(config_error("[data]\nsoftness = 1.0\n"), "data");  // the sensor is the regime's
  EXPECT_EQ(config_error("[fit]\nvalidation_fraction = 1.0\n"), "fit.validation_fraction");
  EXPECT_EQ(config_error("[gate]\nmax_validation_rmse = 0.0\n"), "gate.max_validation_rmse");
  EXPECT_EQ(config_error("[fimm]\nnoise_scale = 0.0\n"), "fimm.noise_scale");
  EXPECT_EQ(config_error("[fimm]\niekf_iterations = 1\n"), "fimm.iekf_iterations");
  EXPECT_EQ(config_error("[fimm]\ntransition = [[0.9, 0.2], [0.1, 0.9]]\n"), "fimm.transition");
  EXPECT_EQ(config_error("[fimm]\nsample_period = 0.2\n"), "fimm.sample_period");  // regime's
  EXPECT_EQ(config_error("[fimm]\ntransition = \"learned\"\n"), "fimm.transition");
  EXPECT_EQ(config_error("[fimm]\ntransition = \"sojourns\"\n"), "");
  // A regime without a range sensor is refused under the config's `regime` key.
  EXPECT_EQ(testing::config_error_key("regime = \"configs/regimes/paper/wimm_training.toml\"\n",
                                      [](const auto& path) { return load_tsk_config(path); }),
            "regime");
  const TskTrainingConfig shipped = load_tsk_config("configs/tsk_range_sensor.toml");
  EXPECT_EQ(shipped.regime.sensor.calibration.samples, 8000);
  EXPECT_EQ(shipped.fimm.sample_period, shipped.regime.sample_period);
  EXPECT_EQ(shipped.fcrm.clusters, 3);
  EXPECT_EQ(shipped.t_norm, TNorm::kMin);
  const TskTrainingConfig hard = load_tsk_config("configs/tsk_range_sensor_hard.toml");
  EXPECT_EQ(hard.regime.sensor.distortion.softness, 10.0);
}

TEST(TskTraining, SmallRunWritesAModelThatReproducesTheSensor) {
  const testing::TempDir dir;
  TskTrainingConfig config = load_tsk_config("configs/tsk_range_sensor.toml");
  config.regime.sensor.calibration.samples = 1200;
  config.fcrm.restarts = 3;
  const auto out = dir / "models" / "tsk.h5";
  const TskTrainingResult result = train_tsk(config, out);
  ASSERT_TRUE(result.gate_passed);
  EXPECT_EQ(result.training_samples + result.validation_samples, 1200);
  for (const OutputReport& r : result.outputs) {
    EXPECT_LT(r.validation_rmse, r.fcrm_validation_rmse);
    EXPECT_DOUBLE_EQ(r.sigma, r.training_rmse);  // eq. (7)
  }
  const TskSensorModel model = io::read_tsk_sensor(out);
  // The box is the training inputs' extent, inside the data box.
  EXPECT_GE(model.input_lower()(1), 1.0);
  EXPECT_LE(model.input_upper()(1), 100.0);
  EXPECT_GT(model.input_upper()(1), 95.0);
  // Against the noise-free distortion at fresh points: a few sensor noise levels.
  datasets::Rng rng(77);
  double worst = 0.0;
  for (int k = 0; k < 200; ++k) {
    const Eigen::Vector2d p(rng.uniform(-5.0, 5.0), rng.uniform(5.0, 95.0));
    const Eigen::Vector2d truth = config.regime.sensor.response(p);
    worst = std::max(worst, (model.evaluate(p).value - truth).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1.0);
  const auto metrics =
      nlohmann::json::parse(testing::slurp_text(dir / "models" / "tsk.metrics.json"));
  EXPECT_TRUE(metrics["gate"]["passed"].get<bool>());
  EXPECT_EQ(metrics["outputs"]["z2"]["validation_rmse"].get<double>(),
            result.outputs[1].validation_rmse);

  // A gate nothing can pass: metrics are written, the model is not.
  config.max_validation_rmse = 1e-9;
  const auto refused = dir / "models" / "refused.h5";
  EXPECT_FALSE(train_tsk(config, refused).gate_passed);
  EXPECT_FALSE(std::filesystem::exists(refused));
  EXPECT_TRUE(std::filesystem::exists(dir / "models" / "refused.metrics.json"));
}

// `fimm.transition = "sojourns"`: the FIMM's transitions are the chain learned from the training
// tracks' maneuver labels. In the seed's cut-in (T = 0.1 s, 200 scans) every track cruises over
// scans 0–9, 40–139 and 180–199 and changes lane over 10–39 and 140–179: per track 129 scan-to-
// scan steps from cruise with 2 exits, 70 from a lane change with 2 exits, so P̂ = [[1 − a, a],
// [b, 1 − b]] with a = 2/129, b = 2/70. For two states log P̂ = log(1 − a − b) / (−(a + b)) ·
// (P̂ − I), so the mean sojourns are (a + b) T / (a · −log(1 − a − b)) ≈ 6.31 s and the same with
// b ≈ 3.42 s (not 6.45 and 3.5: the logarithm corrects for changes between samples).
TEST(TskTraining, LearnsTheFimmsTransitionsFromTheTrainingTracksSojourns) {
  const testing::TempDir dir;
  TskTrainingConfig config = load_tsk_config("configs/tsk_range_sensor.toml");
  config.regime.sensor.calibration.samples = 600;
  config.fcrm.restarts = 2;
  config.fine_tuning.max_iterations = 5;
  config.transitions_from_sojourns = true;
  const auto out = dir / "tsk.h5";
  const TskTrainingResult result = train_tsk(config, out);
  ASSERT_TRUE(result.sojourns.has_value());
  const double a = 2.0 / 129.0, b = 2.0 / 70.0, T = 0.1;
  const double decay = -std::log(1.0 - a - b);
  EXPECT_NEAR(result.sojourns->mean_sojourn(0), (a + b) * T / (a * decay), 1e-9);
  EXPECT_NEAR(result.sojourns->mean_sojourn(1), (a + b) * T / (b * decay), 1e-9);
  // exp(Q T) of a two-state chain: P(leave) = r_i / (r_0 + r_1) (1 − e^{−(r_0 + r_1) T}).
  const double r0 = 1.0 / result.sojourns->mean_sojourn(0),
               r1 = 1.0 / result.sojourns->mean_sojourn(1);
  const double leave = 1.0 - std::exp(-(r0 + r1) * T);
  EXPECT_NEAR(result.fimm.transition(0, 1), r0 / (r0 + r1) * leave, 1e-12);
  EXPECT_NEAR(result.fimm.transition(1, 0), r1 / (r0 + r1) * leave, 1e-12);
  if (result.gate_passed) {
    const std::optional<FimmSpec> stored = io::read_fimm_settings(io::ModelFileReader(out));
    ASSERT_TRUE(stored.has_value());
    EXPECT_EQ(stored->transition, result.fimm.transition);
  }
  const auto metrics = nlohmann::json::parse(testing::slurp_text(dir / "tsk.metrics.json"));
  EXPECT_EQ(metrics["fimm_transition"]["source"], "sojourns");
  // Without it, the config's matrix.
  config.transitions_from_sojourns = false;
  const TskTrainingResult preset = train_tsk(config, dir / "preset.h5");
  EXPECT_FALSE(preset.sojourns.has_value());
  EXPECT_EQ(preset.fimm.transition, config.fimm.transition);
}

}  // namespace
}  // namespace imm::trainer::tsk
