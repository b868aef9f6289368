// SPDX-License-Identifier: Apache-2.0
// End-to-end, continued (train_and_evaluate_test.cpp has the plain IMM, the GA-fuzzy IMM, the
// input estimator and the regime's tracker): a polar regime's tracker, then the wIMM, the FCM-IMM
// and the TSK sensor model trained and evaluated.

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "testing/regime_files.hpp"
#include "testing/shipped_tracker.hpp"
#include "testing/tools_fixture.hpp"

// The fixture and its helpers are imm::testing's (testing/tools_fixture.hpp).
namespace imm::testing {
namespace {

TEST_F(Tools, APolarRegimesTrackerIsChosenAmongItsWimmAndItsTunedNormalImm) {
  std::string text = testing::slurp(config("configs/regimes/air_surveillance.toml"));
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"name = \"air_surveillance\"", "name = \"polar_small\""},
           {"scans = 120", "scans = 40"},
           {"azimuth_sigma_deg = 0.2", "azimuth_sigma_deg = 0.2\nposition = [30000.0, -20000.0]"},
           {"training = 24", "training = 3"},
           {"validation = 8", "validation = 2"},
           {"test = 100", "test = 10"}}) {
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  }
  const auto regime = dir_ / "polar_small.toml";
  testing::write_text(regime, text);
  const auto models = dir_ / "models";
  const std::string wimm_config = config("configs/wimm_tuned.toml").string();
  // Without --config, a polar regime's baseline is the normal IMM of configs/wimm_tuned.toml (the
  // default GA config's filter is Cartesian: it was refused naming the GA config).
  const auto baseline = run_tool(
      "imm-train",
      {"baseline", "--regime", regime.string(), "--out", (models / "baseline.h5").string()}, root_);
  ASSERT_EQ(baseline.exit_code, 0) << baseline.err;
  EXPECT_NE(baseline.err.find("the normal IMM tuned on the training split"), std::string::npos)
      << baseline.err;
  // A range sensor's bar is not a file: refused naming sensor.kind, not the GA config's filter.
  const auto range = run_tool("imm-train",
                              {"baseline", "--regime", "configs/regimes/paper/fimm_table1.toml",
                               "--out", (models / "range.h5").string()},
                              root_);
  EXPECT_EQ(range.exit_code, 2) << range.err;
  EXPECT_NE(range.err.find("fimm_table1.toml: key 'sensor.kind': regime 'fimm_table1' has a "
                           "range sensor: its classical bar is the IMM (h = identity)"),
            std::string::npos)
      << range.err;
  const auto trained = train("wimm", wimm_config, regime, models / "wimm.h5");
  ASSERT_EQ(trained.exit_code, 0) << trained.err;

  const auto tracker = dir_ / "shipped" / "polar_small" / "tracker.h5";
  const auto ranked = run_tool("imm-eval",
                               {"rank", "--baseline", (models / "baseline.h5").string(),
                                "--candidates", (models / "wimm.h5").string(), "--out",
                                (dir_ / "rank").string(), "--ship", tracker.string()},
                               root_);
  ASSERT_TRUE(ranked.exit_code == 0 || ranked.exit_code == 7) << ranked.err;
  EXPECT_NE(ranked.out.find("regime polar_small test split"), std::string::npos) << ranked.out;
  const auto choice = nlohmann::json::parse(testing::slurp(dir_ / "rank" / "tracker.json"));
  ASSERT_EQ(choice["ranking"].size(), 2u);
  for (const auto& row : choice["ranking"]) {
    // Scored around the sensor: better than the plots themselves (a filter scored in the wrong
    // frame would be 36 km off, ζ in the hundreds), with a finite NEES.
    EXPECT_GT(row["zeta_p"].get<double>(), 0.0) << row.dump();
    EXPECT_LT(row["zeta_p"].get<double>(), 1.0) << row.dump();
    EXPECT_LT(row["zeta_v"].get<double>(), 1.0) << row.dump();
    EXPECT_TRUE(std::isfinite(row["position_nees"].get<double>())) << row.dump();
  }
  testing::expect_winner_with_calibration(tracker,
                                          models / (choice["tracker"].get<std::string>() + ".h5"));
  // A wIMM whose fusion is off is its tuned normal IMM: the same figures, to the bit.
  const auto wimm_metrics = nlohmann::json::parse(testing::slurp(models / "wimm.metrics.json"));
  if (!wimm_metrics.at("learned_part_on").get<bool>()) {
    EXPECT_EQ(choice["ranking"][0]["zeta_p"], choice["ranking"][1]["zeta_p"]);
    EXPECT_EQ(choice["tracker"], "baseline");
  }
}

// A regime generated in the test (the training regime with 3 tracks): trains, records the regime,
// and evaluates on the paper's two scenarios with every baseline.
TEST_F(Tools, WimmTrainingAndEvaluationEndToEnd) {
  const auto regime =
      testing::write_preset_variant(dir_, "wimm_training", {{"training = 24", "training = 3"}});
  std::string config = testing::slurp(this->config("configs/wimm.toml"));
  config.replace(config.find("max_evaluations = 150"), 21, "max_evaluations = 40");
  testing::write_text(dir_ / "wimm.toml", config);
  const auto models = dir_ / "models";
  const auto trained = train("wimm", dir_ / "wimm.toml", regime, models / "wimm.h5");
  ASSERT_EQ(trained.exit_code, 0) << trained.err;
  EXPECT_NE(trained.err.find("threshold"), std::string::npos) << trained.err;
  const auto inspected = run_tool("imm-inspect", {(models / "wimm.h5").string()}, root_);
  ASSERT_EQ(inspected.exit_code, 0) << inspected.err;
  EXPECT_NE(inspected.out.find("kind             wimm"), std::string::npos);
  EXPECT_NE(inspected.out.find("regime_name      wimm_training"), std::string::npos)
      << inspected.out;

  const auto out = dir_ / "report";
  const auto evaluated =
      run_tool("imm-eval",
               {"wimm", "--models", models.string(), "--regime",
                "configs/regimes/paper/wimm_table2.toml", "--runs", "6", "--out", out.string()},
               root_);
  ASSERT_TRUE(evaluated.exit_code == 0 || evaluated.exit_code == 5 || evaluated.exit_code == 7)
      << evaluated.err;
  EXPECT_NE(evaluated.out.find("cannot come from plots"), std::string::npos);
  EXPECT_NE(evaluated.out.find("off its training maneuvers"), std::string::npos);
  const auto metrics = evaluation_results(out);
  EXPECT_GE(consistency_headlines(out), 1);  // one per scenario: the regression gate's consistency
  for (const char* scenario : {"scenario 1", "scenario 2"}) {
    for (const char* filter : {"nIMM", "wIMM", "nIMM-tuned"}) {
      ASSERT_TRUE(metrics[scenario].contains(filter)) << scenario << " " << filter;
      for (const char* key :
           {"az_rmse", "az_rmse_settled", "pos_rmse", "pos_rmse_settled", "nees"}) {
        EXPECT_GT(metrics[scenario][filter][key].get<double>(), 0.0) << key;
      }
    }
    // The correlated fusion is the normal IMM, also through the whole evaluation.
    EXPECT_NEAR(metrics[scenario]["wIMM-correlated"]["az_rmse"].get<double>(),
                metrics[scenario]["nIMM"]["az_rmse"].get<double>(), 1e-9);
  }
  EXPECT_TRUE(std::filesystem::exists(out / "case1_azimuth_rmse.csv"));

  // A regime with another sample period is refused, naming the field.
  const auto slow = testing::write_preset_variant(dir_, "wimm_table2",
                                                  {{"sample_period = 2.0", "sample_period = 4.0"}});
  const auto refused = run_tool("imm-eval",
                                {"wimm", "--models", models.string(), "--regime", slow.string(),
                                 "--runs", "2", "--out", (dir_ / "refused").string()},
                                root_);
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("sample_period"), std::string::npos) << refused.err;
}

TEST_F(Tools, FcmTrainingAndEvaluationEndToEnd) {
  std::string config = testing::slurp(this->config("configs/fcm_imm.toml"));
  auto replace = [&](const std::string& from, const std::string& to) {
    ASSERT_NE(config.find(from), std::string::npos) << from;
    config.replace(config.find(from), from.size(), to);
  };
  replace("windows = [8, 16, 32]", "windows = [8]");
  replace("max_evaluations = 150", "max_evaluations = 10");
  testing::write_text(dir_ / "fcm.toml", config);
  const auto models = dir_ / "models";
  const auto trained =
      run_tool("imm-train",
               {"fcm", "--config", (dir_ / "fcm.toml").string(), "--regime",
                testing::write_preset_variant(
                    dir_, "fcm_imm_training",
                    {{"training = 16", "training = 3"}, {"validation = 8", "validation = 2"}})
                    .string(),
                "--out", (models / "fcm_imm.h5").string(), "--seed", "4"},
               root_);
  ASSERT_EQ(trained.exit_code, 0) << trained.err;
  // Either a fit with a compensation beats the tuned IMM, or the model says it is that IMM.
  EXPECT_TRUE(
      trained.err.find("fitted: window 8") != std::string::npos ||
      (trained.err.find("fitted: the constant-q IMM (learned part off") != std::string::npos &&
       trained.err.find("learned part switched off") != std::string::npos))
      << trained.err;
  const auto inspected = run_tool("imm-inspect", {(models / "fcm_imm.h5").string()}, root_);
  ASSERT_EQ(inspected.exit_code, 0) << inspected.err;
  EXPECT_NE(inspected.out.find("kind             fcm_imm"), std::string::npos);
  EXPECT_NE(inspected.out.find("mean_memberships"), std::string::npos) << inspected.out;

  const auto out = dir_ / "report";
  const auto evaluated = run_tool(
      "imm-eval", {"fcm-imm", "--models", models.string(), "--runs", "4", "--out", out.string()},
      root_);
  ASSERT_TRUE(evaluated.exit_code == 0 || evaluated.exit_code == 5 || evaluated.exit_code == 7)
      << evaluated.err;
  EXPECT_NE(evaluated.out.find("FCM-IMM-const"), std::string::npos);
  // Every tuned quantity with its unit (the seed's regime is in m).
  EXPECT_NE(evaluated.out.find("(m/s²)² ("), std::string::npos) << evaluated.out;
  EXPECT_NE(evaluated.out.find(" m/s², σ_w "), std::string::npos) << evaluated.out;
  const auto metrics = evaluation_results(out);
  EXPECT_EQ(consistency_headlines(out), 1);  // the regression gate holds back a less consistent one
  ASSERT_EQ(metrics.size(), 5u);
  for (const char* filter : {"KF", "AIMM", "IMM-tuned", "FCM-IMM", "FCM-IMM-const"}) {
    ASSERT_TRUE(metrics.contains(filter)) << filter;
    for (const char* key : {"pos_rmse", "vel_rmse", "pos_rmse_maneuver", "vel_rmse_maneuver"}) {
      const double value = metrics[filter][key].get<double>();
      EXPECT_GT(value, 0.0) << filter << " " << key;
      EXPECT_LT(value, 1000.0) << filter << " " << key;  // m, m/s: nothing diverged
    }
  }
  EXPECT_TRUE(std::filesystem::exists(out / "position_rmse.csv"));
  EXPECT_NE(evaluated.out.find("the model's own"), std::string::npos) << evaluated.out;

  // Its learned part off (λ held at 0), the model is the IMM its trainer tuned, and the
  // experiment's IMM-tuned is that same IMM (one objective, one search, one baseline): the two
  // rows agree in every figure, to rounding.
  replace("compensation_gain = [0.0, 1.0]", "compensation_gain = [0.0, 0.0]");
  testing::write_text(dir_ / "fcm_off.toml", config);
  const auto off = run_tool("imm-train",
                            {"fcm", "--config", (dir_ / "fcm_off.toml").string(), "--regime",
                             (dir_ / "fcm_imm_training.toml").string(), "--out",
                             (models / "fcm_off.h5").string(), "--seed", "4"},
                            root_);
  ASSERT_EQ(off.exit_code, 0) << off.err;
  EXPECT_NE(off.err.find("learned part switched off"), std::string::npos) << off.err;
  // On 3 training tracks, fewer than the kind's learning curve needs: said, naming the key.
  EXPECT_NE(off.err.find("switched off on splits.training = 3 tracks"), std::string::npos)
      << off.err;
  const auto off_evaluated = run_tool("imm-eval",
                                      {"fcm-imm", "--models", models.string(), "--model", "fcm_off",
                                       "--runs", "4", "--out", (dir_ / "off-report").string()},
                                      root_);
  ASSERT_TRUE(off_evaluated.exit_code == 0 || off_evaluated.exit_code == 5 ||
              off_evaluated.exit_code == 7)
      << off_evaluated.err;
  const auto off_metrics = evaluation_results(dir_ / "off-report");
  for (const char* key : {"pos_rmse", "vel_rmse", "pos_rmse_maneuver", "vel_rmse_maneuver"}) {
    const double tuned = off_metrics["IMM-tuned"][key].get<double>();
    EXPECT_NEAR(off_metrics["FCM-IMM"][key].get<double>(), tuned, 1e-9 * tuned) << key;
  }

  // A model that is not an fcm_imm file is refused with exit code 2.
  std::filesystem::create_directories(dir_ / "wrong");
  std::filesystem::copy_file(this->config("models/wimm.h5"), dir_ / "wrong" / "fcm_imm.h5");
  const auto wrong = run_tool("imm-eval",
                              {"fcm-imm", "--models", (dir_ / "wrong").string(), "--runs", "2",
                               "--out", (dir_ / "wrong-report").string()},
                              root_);
  EXPECT_EQ(wrong.exit_code, 2);
  EXPECT_NE(wrong.err.find("fcm_imm"), std::string::npos) << wrong.err;
}

TEST_F(Tools, TskTrainingAndFimmEvaluationEndToEnd) {
  const auto models = dir_ / "models";
  for (const std::string stem : {"tsk_range_sensor", "tsk_range_sensor_hard"}) {
    const bool hard = stem == "tsk_range_sensor_hard";
    const auto regime = testing::write_preset_variant(
        dir_, hard ? "fimm_table1_hard" : "fimm_table1", {{"samples = 8000", "samples = 1500"}});
    std::string config = testing::slurp(this->config("configs/" + stem + ".toml"));
    config.replace(config.find("restarts = 10"), 13, "restarts = 3");
    testing::write_text(dir_ / (stem + ".toml"), config);
    const auto trained =
        run_tool("imm-train",
                 {"tsk", "--config", (dir_ / (stem + ".toml")).string(), "--regime",
                  regime.string(), "--out", (models / (stem + ".h5")).string(), "--seed", "3"},
                 root_);
    ASSERT_EQ(trained.exit_code, 0) << trained.err;
    EXPECT_NE(trained.err.find("fine tuning"), std::string::npos) << trained.err;
    const auto metrics = nlohmann::json::parse(testing::slurp(models / (stem + ".metrics.json")));
    for (const char* z : {"z1", "z2"}) {
      EXPECT_LT(metrics["outputs"][z]["validation_rmse"].get<double>(),
                metrics["outputs"][z]["fcrm_validation_rmse"].get<double>())
          << stem << " " << z;
    }
  }
  const auto inspected =
      run_tool("imm-inspect", {(models / "tsk_range_sensor.h5").string()}, root_);
  ASSERT_EQ(inspected.exit_code, 0) << inspected.err;
  EXPECT_NE(inspected.out.find("kind             tsk_sensor"), std::string::npos) << inspected.out;
  EXPECT_NE(inspected.out.find("/tsk/output2/rules"), std::string::npos) << inspected.out;
  EXPECT_NE(inspected.out.find("center_eta"), std::string::npos) << inspected.out;
  // The FIMM it was evaluated in travels with it (imm::load_filter needs nothing else).
  EXPECT_NE(inspected.out.find("/fimm/measurement_covariance"), std::string::npos) << inspected.out;

  for (const std::string sensor : {"default", "hard"}) {
    const bool hard = sensor == "hard";
    const std::string stem = hard ? "tsk_range_sensor_hard" : "tsk_range_sensor";
    const auto out = dir_ / ("report-" + sensor);
    const auto evaluated =
        run_tool("imm-eval",
                 {"fimm", "--models", models.string(), "--model", stem, "--config",
                  (dir_ / (stem + ".toml")).string(), "--runs", "8", "--out", out.string()},
                 root_);
    ASSERT_TRUE(evaluated.exit_code == 0 || evaluated.exit_code == 5 || evaluated.exit_code == 7)
        << evaluated.err;
    EXPECT_NE(evaluated.out.find("clamped"), std::string::npos) << evaluated.out;
    const auto metrics = evaluation_results(out);
    EXPECT_EQ(consistency_headlines(out) % 2, 0);  // the FIMM (EKF) and (IEKF) per case
    EXPECT_GE(consistency_headlines(out), 2);
    ASSERT_EQ(metrics["rows"].size(), 4u);
    const double expected_r[4] = {0.01, 0.25, 1.0, 4.0};
    for (std::size_t i = 0; i < 4; ++i) {
      const auto& row = metrics["rows"][i];
      EXPECT_DOUBLE_EQ(row["R"].get<double>(), expected_r[i]);
      for (const char* key : {"imm_mse", "fimm_mse"}) {
        EXPECT_GT(row[key].get<double>(), 0.0) << sensor << " " << key;
        EXPECT_LT(row[key].get<double>(), 100.0) << sensor << " " << key;  // nothing diverged
      }
      EXPECT_TRUE(row.contains("fimm_clamped_share")) << sensor;
    }
    for (const char* file : {"case0_path.csv", "case3_path.csv", "sensor_model.csv",
                             "mse_by_scan.csv", "details.json"}) {
      EXPECT_TRUE(std::filesystem::exists(out / file)) << sensor << " " << file;
    }
  }

  // A model fitted to one sensor is refused on a regime with another, naming the field.
  const auto refused = run_tool("imm-eval",
                                {"fimm", "--models", models.string(), "--regime",
                                 "configs/regimes/paper/fimm_table1_hard.toml", "--config",
                                 (dir_ / "tsk_range_sensor.toml").string(), "--runs", "4", "--out",
                                 (dir_ / "refused").string()},
                                root_);
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("sensor.knee/softness"), std::string::npos) << refused.err;

  // A model of another kind in its place is refused with exit code 2.
  std::filesystem::create_directories(dir_ / "wrong");
  std::filesystem::copy_file(this->config("models/wimm.h5"),
                             dir_ / "wrong" / "tsk_range_sensor.h5");
  const auto wrong = run_tool("imm-eval",
                              {"fimm", "--models", (dir_ / "wrong").string(), "--config",
                               (dir_ / "tsk_range_sensor.toml").string(), "--runs", "2", "--out",
                               (dir_ / "wrong-report").string()},
                              root_);
  EXPECT_EQ(wrong.exit_code, 2);
  EXPECT_NE(wrong.err.find("tsk_sensor"), std::string::npos) << wrong.err;
}

// Samples of a sensor (a data set here, a CSV below) become the regime's sensor: the TSK model is
// fitted to them, and `--data` accepts only the samples its regime names.
TEST_F(Tools, TskTrainingFromStoredSamples) {
  const auto drawn = dir_ / "drawn.toml";
  std::filesystem::rename(
      testing::write_preset_variant(dir_, "fimm_table1", {{"samples = 8000", "samples = 1200"}}),
      drawn);
  const auto data = run_tool(
      "imm-data", {"sensor", "--regime", drawn.string(), "--out", (dir_ / "r.h5").string()}, root_);
  ASSERT_EQ(data.exit_code, 0) << data.err;
  std::string config = testing::slurp(this->config("configs/tsk_range_sensor.toml"));
  config.replace(config.find("restarts = 10"), 13, "restarts = 2");
  auto regime_of_samples = [&](const std::filesystem::path& samples, const std::string& name) {
    const auto path = testing::write_preset_variant(
        dir_, "fimm_table1",
        {{"knee = 40.0\nsoftness = 30.0", "samples = \"" + samples.string() + "\""},
         {"name = \"fimm_table1\"", "name = \"" + name + "\""}});
    const auto renamed = dir_ / (name + ".toml");
    std::filesystem::rename(path, renamed);
    testing::write_text(dir_ / (name + "_tsk.toml"), "regime = \"" + renamed.string() + "\"\n" +
                                                         config.substr(config.find("seed = 1")));
    return dir_ / (name + "_tsk.toml");
  };
  const auto sampled = regime_of_samples(dir_ / "r.h5", "sampled");
  const auto trained = run_tool("imm-train",
                                {"tsk", "--config", sampled.string(), "--data",
                                 (dir_ / "r.h5").string(), "--out", (dir_ / "m.h5").string()},
                                root_);
  ASSERT_EQ(trained.exit_code, 0) << trained.err;
  EXPECT_NE(trained.err.find("1200 samples from"), std::string::npos) << trained.err;
  // The model records the digest of the data set it was fitted on.
  const auto model = nlohmann::json::parse(
      run_tool("imm-inspect", {(dir_ / "m.h5").string(), "--json"}, root_).out);
  const auto stored = nlohmann::json::parse(
      run_tool("imm-inspect", {(dir_ / "r.h5").string(), "--json"}, root_).out);
  EXPECT_EQ(model["attributes"]["dataset_digest"], stored["attributes"]["digest"]);
  // Samples the regime does not name are refused under the config's `regime` key.
  testing::write_text(dir_ / "drawn_tsk.toml", "regime = \"" + drawn.string() + "\"\n" +
                                                   config.substr(config.find("seed = 1")));
  const auto other = run_tool("imm-train",
                              {"tsk", "--config", (dir_ / "drawn_tsk.toml").string(), "--data",
                               (dir_ / "r.h5").string(), "--out", (dir_ / "o.h5").string()},
                              root_);
  EXPECT_EQ(other.exit_code, 2) << other.err;
  EXPECT_NE(other.err.find("regime"), std::string::npos) << other.err;

  // A CSV of a (here: synthetic, linear) sensor; a bad row is named by its line.
  std::string csv = "# xi, eta true; z1, z2 measured\nxi,eta,z1,z2\n";
  for (int q = 0; q < 200; ++q) {
    const double xi = -5.0 + 0.05 * q, eta = 1.0 + 0.47 * ((q * 37) % 200);
    csv += std::to_string(xi) + "," + std::to_string(eta) + "," + std::to_string(0.9 * xi) + "," +
           std::to_string(0.8 * eta) + "\n";
  }
  testing::write_text(dir_ / "s.csv", csv);
  const auto from_csv =
      run_tool("imm-train",
               {"tsk", "--config", regime_of_samples(dir_ / "s.csv", "csv").string(), "--out",
                (dir_ / "c.h5").string()},
               root_);
  ASSERT_EQ(from_csv.exit_code, 0) << from_csv.err;
  const auto metrics = nlohmann::json::parse(testing::slurp(dir_ / "c.metrics.json"));
  EXPECT_LT(metrics["outputs"]["z2"]["validation_rmse"].get<double>(), 0.01);  // a plane: exact
  testing::write_text(dir_ / "bad.csv", "xi,eta,z1,z2\n1,2,3,4\n1,nan,3,4\n");
  const auto bad = run_tool("imm-train",
                            {"tsk", "--config", regime_of_samples(dir_ / "bad.csv", "bad").string(),
                             "--out", (dir_ / "b.h5").string()},
                            root_);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("bad.csv:3"), std::string::npos) << bad.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "b.h5"));
}

}  // namespace
}  // namespace imm::testing
