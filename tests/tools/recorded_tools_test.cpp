// SPDX-License-Identifier: Apache-2.0
// End-to-end: recorded tracks through the tools, as a user would bring them — exported without
// truth, imported, named by a recorded regime, and evaluated by the plots alone.

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "testing/tools_fixture.hpp"

namespace imm {
namespace {

using testing::kTable3;
using testing::run_tool;
using testing::Tools;

TEST_F(Tools, RecordingsExportedWithoutTruthImportAndEvaluateByTheirPlots) {
  const auto exported = run_tool("imm-data",
                                 {"export", "--regime", kTable3, "--count", "6", "--out-dir",
                                  (dir_ / "rec").string(), "--no-truth"},
                                 root_);
  ASSERT_EQ(exported.exit_code, 0) << exported.err;
  const std::string header = testing::lines_of(testing::slurp(dir_ / "rec" / "track_000.csv"))[0];
  EXPECT_EQ(header, "t,zx,zy");
  std::vector<std::string> import = {"import", "--out", (dir_ / "rec.h5").string(), "--units",
                                     "km"};
  for (int i = 0; i < 6; ++i) {
    import.push_back((dir_ / "rec" / ("track_00" + std::to_string(i) + ".csv")).string());
  }
  const auto imported = run_tool("imm-data", import, root_);
  ASSERT_EQ(imported.exit_code, 0) << imported.err;
  EXPECT_NE(imported.out.find("6 recordings, 6 tracks"), std::string::npos) << imported.out;
  EXPECT_NE(imported.out.find("without truth"), std::string::npos) << imported.out;

  // The set as data for the plain IMM: judged by the plots, headline without ζ.
  const auto evaluated = run_tool("imm-eval",
                                  {"plain-imm", "--model", "models/cv3_imm.h5", "--data",
                                   (dir_ / "rec.h5").string(), "--out", (dir_ / "e").string()},
                                  root_);
  ASSERT_TRUE(evaluated.exit_code == 0 || evaluated.exit_code == 7) << evaluated.err;
  EXPECT_NE(evaluated.out.find("the tracks have no truth"), std::string::npos) << evaluated.out;
  const auto headline = nlohmann::json::parse(testing::slurp(dir_ / "e" / "headline.json"));
  std::vector<std::string> names;
  for (const auto& m : headline["metrics"]) names.push_back(m["name"]);
  EXPECT_EQ(names, (std::vector<std::string>{"predictive_nll", "nis_log_ratio", "innovation_rms"}));
  for (const auto& m : headline["metrics"]) EXPECT_TRUE(std::isfinite(m["value"].get<double>()));

  // A recorded regime without truth: the tuned baseline learns from the plots' likelihood.
  std::ofstream(dir_ / "recorded.toml")
      << "name = \"rec\"\nunits = \"km\"\n[recorded]\nset = \"" << (dir_ / "rec.h5").string()
      << "\"\nacceleration = [0.01, 0.05]\n[sensor]\nkind = \"cartesian\"\nsigma = [0.5, 0.5]\n"
         "[splits]\ntraining = 2\nvalidation = 2\ntest = 2\n";
  const auto trained =
      run_tool("imm-train",
               {"baseline", "--config", "configs/ga_fuzzy_imm_tuned.toml", "--regime",
                (dir_ / "recorded.toml").string(), "--out", (dir_ / "b.h5").string()},
               root_);
  ASSERT_EQ(trained.exit_code, 0) << trained.err;
  EXPECT_NE(trained.err.find("excess NLL per plot"), std::string::npos) << trained.err;
  const auto inspected = nlohmann::json::parse(
      run_tool("imm-inspect", {(dir_ / "b.h5").string(), "--json"}, root_).out);
  EXPECT_EQ(inspected["attributes"]["training.trained_without_truth"], 1.0) << inspected.dump();
  // Its own regime's test recordings judge it by the plots: ga-imm and rank.
  const auto ga = run_tool(
      "imm-eval", {"ga-imm", "--model", (dir_ / "b.h5").string(), "--out", (dir_ / "g").string()},
      root_);
  ASSERT_TRUE(ga.exit_code == 0 || ga.exit_code == 7) << ga.err;
  EXPECT_NE(ga.out.find("log-likelihood per plot"), std::string::npos) << ga.out;
  const auto ga_headline = nlohmann::json::parse(testing::slurp(dir_ / "g" / "headline.json"));
  EXPECT_EQ(ga_headline["metrics"][0]["name"], "predictive_nll");
  const auto ranked = run_tool("imm-eval",
                               {"rank", "--baseline", (dir_ / "b.h5").string(), "--candidates",
                                (dir_ / "b.h5").string(), "--out", (dir_ / "r").string()},
                               root_);
  ASSERT_TRUE(ranked.exit_code == 0 || ranked.exit_code == 7) << ranked.err;
  const auto tracker = nlohmann::json::parse(testing::slurp(dir_ / "r" / "tracker.json"));
  EXPECT_FALSE(tracker["truth"].get<bool>());
  EXPECT_TRUE(tracker["ranking"][0].contains("predictive_nll"));
  EXPECT_FALSE(tracker["ranking"][0].contains("zeta_p"));

  // The FCM-IMM learns from the plots too, and its experiment judges it by them.
  const auto fcm = run_tool("imm-train",
                            {"fcm", "--config", "configs/fcm_imm.toml", "--regime",
                             (dir_ / "recorded.toml").string(), "--out", (dir_ / "f.h5").string()},
                            root_);
  ASSERT_EQ(fcm.exit_code, 0) << fcm.err;
  const auto fcm_eval = run_tool(
      "imm-eval", {"fcm-imm", "--model", (dir_ / "f.h5").string(), "--out", (dir_ / "fe").string()},
      root_);
  ASSERT_TRUE(fcm_eval.exit_code == 0 || fcm_eval.exit_code == 7) << fcm_eval.err;
  EXPECT_NE(fcm_eval.out.find("FCM-IMM − this NLL per plot"), std::string::npos) << fcm_eval.out;
  // The input estimator learns the smoother's accelerations, and is judged by the plots.
  const auto mlp =
      run_tool("imm-train",
               {"mlp", "--config", "configs/mlp_input_estimator_tuned.toml", "--regime",
                (dir_ / "recorded.toml").string(), "--out", (dir_ / "i.h5").string()},
               root_);
  ASSERT_EQ(mlp.exit_code, 0) << mlp.err;
  EXPECT_NE(mlp.err.find("labels (no truth)"), std::string::npos) << mlp.err;
  const auto mlp_eval = run_tool(
      "imm-eval",
      {"input-estimator", "--model", (dir_ / "i.h5").string(), "--out", (dir_ / "ie").string()},
      root_);
  ASSERT_TRUE(mlp_eval.exit_code == 0 || mlp_eval.exit_code == 7) << mlp_eval.err;
  EXPECT_NE(mlp_eval.out.find("corrected KF − this NLL per plot"), std::string::npos)
      << mlp_eval.out;

  // The TSK sensor model needs calibration positions: refused, saying why.
  const auto refused =
      run_tool("imm-train",
               {"tsk", "--config", "configs/tsk_range_sensor.toml", "--regime",
                (dir_ / "recorded.toml").string(), "--out", (dir_ / "m.h5").string()},
               root_);
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("recorded.truth"), std::string::npos) << refused.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "m.h5"));
}

// Polar recordings: the wIMM and its nIMM baseline learn from the plots alone, and imm-eval wimm
// judges them by the plots.
TEST_F(Tools, PolarRecordingsTrainAndEvaluateTheWimmWithoutTruth) {
  const auto exported =
      run_tool("imm-data",
               {"export", "--regime", "configs/regimes/air_surveillance.toml", "--count", "6",
                "--out-dir", (dir_ / "rec").string(), "--no-truth"},
               root_);
  ASSERT_EQ(exported.exit_code, 0) << exported.err;
  const auto wrong_sensor = run_tool(
      "imm-data", {"import", "--out", (dir_ / "p.h5").string(), (dir_ / "rec").string()}, root_);
  EXPECT_EQ(wrong_sensor.exit_code, 2);
  EXPECT_NE(wrong_sensor.err.find("--sensor polar"), std::string::npos) << wrong_sensor.err;
  const auto imported = run_tool("imm-data",
                                 {"import", "--sensor", "polar", "--scans", "60", "--out",
                                  (dir_ / "p.h5").string(), (dir_ / "rec").string()},
                                 root_);
  ASSERT_EQ(imported.exit_code, 0) << imported.err;
  std::ofstream(dir_ / "polar.toml")
      << "name = \"polar_rec\"\nunits = \"m\"\n[recorded]\nset = \"" << (dir_ / "p.h5").string()
      << "\"\n[sensor]\nkind = \"polar\"\nrange_sigma = 100.0\nazimuth_sigma_deg = 0.2\n"
         "[splits]\ntraining = 2\nvalidation = 2\ntest = 2\n";
  const auto trained = run_tool("imm-train",
                                {"wimm", "--config", "configs/wimm_tuned.toml", "--regime",
                                 (dir_ / "polar.toml").string(), "--out", (dir_ / "w.h5").string()},
                                root_);
  ASSERT_EQ(trained.exit_code, 0) << trained.err;
  const auto metrics = nlohmann::json::parse(testing::slurp(dir_ / "w.metrics.json"));
  EXPECT_TRUE(metrics.contains("excess_nll")) << metrics.dump();
  EXPECT_FALSE(metrics.contains("azimuth_ratio_settled")) << metrics.dump();
  const auto inspected = nlohmann::json::parse(
      run_tool("imm-inspect", {(dir_ / "w.h5").string(), "--json"}, root_).out);
  EXPECT_EQ(inspected["attributes"]["training.trained_without_truth"], 1.0) << inspected.dump();
  const auto baseline =
      run_tool("imm-train",
               {"baseline", "--config", "configs/wimm_tuned.toml", "--regime",
                (dir_ / "polar.toml").string(), "--out", (dir_ / "n.h5").string()},
               root_);
  ASSERT_EQ(baseline.exit_code, 0) << baseline.err;
  const auto evaluated = run_tool(
      "imm-eval", {"wimm", "--model", (dir_ / "w.h5").string(), "--out", (dir_ / "we").string()},
      root_);
  ASSERT_TRUE(evaluated.exit_code == 0 || evaluated.exit_code == 7) << evaluated.err;
  EXPECT_NE(evaluated.out.find("wIMM − this NLL per plot"), std::string::npos) << evaluated.out;
  const auto headline = nlohmann::json::parse(testing::slurp(dir_ / "we" / "headline.json"));
  EXPECT_EQ(headline["metrics"][0]["name"], "predictive_nll");
}

TEST_F(Tools, AHostileRecordingIsRefusedAndNothingIsImported) {
  std::filesystem::create_directories(dir_ / "in");
  std::ofstream(dir_ / "in" / "good.csv") << "t,zx,zy\n0,1,2\n1,1.5,2.5\n2,2,3\n3,2.5,3.5\n";
  std::ofstream(dir_ / "in" / "bad.csv") << "t,zx,zy\n0,1,2\n1,1.5,2.5\n2,nan,3\n";
  const auto result =
      run_tool("imm-data",
               {"import", "--out", (dir_ / "set.h5").string(), (dir_ / "in" / "good.csv").string(),
                (dir_ / "in" / "bad.csv").string()},
               root_);
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("bad.csv:4: column 2: 'nan' is not a finite number"), std::string::npos)
      << result.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "set.h5"));
}

}  // namespace
}  // namespace imm
