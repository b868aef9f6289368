// SPDX-License-Identifier: Apache-2.0
// End-to-end: recorded tracks through the tools, as a user would bring them — exported without
// truth, imported, named by a recorded regime, and evaluated by the plots alone.

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <tuple>

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
}

// `count` tracks of the regime file `regime` exported as recordings into dir/`name`/
// (`exported`: more export options), imported with the `imported` options into dir/`name`.h5, and
// a recorded regime over them written to dir/`name`.toml with the [sensor] and [splits] `tables`
// (units m). Returns the regime's path; a tool that fails throws its stderr.
std::filesystem::path recorded_regime(const std::filesystem::path& root,
                                      const std::filesystem::path& dir, const std::string& name,
                                      const std::string& regime, int count,
                                      const std::vector<std::string>& exported,
                                      const std::vector<std::string>& imported,
                                      const std::string& tables) {
  std::vector<std::string> export_args = {
      "export",    "--regime",           regime, "--count", std::to_string(count),
      "--out-dir", (dir / name).string()};
  export_args.insert(export_args.end(), exported.begin(), exported.end());
  std::vector<std::string> import_args = {"import", "--out", (dir / (name + ".h5")).string()};
  import_args.insert(import_args.end(), imported.begin(), imported.end());
  import_args.push_back((dir / name).string());
  for (const auto& [tool, args] : {std::pair{"imm-data", export_args}, {"imm-data", import_args}}) {
    const auto result = run_tool(tool, args, root);
    if (result.exit_code != 0) throw std::runtime_error(args[0] + ": " + result.err);
  }
  std::filesystem::path path = dir / (name + ".toml");
  std::ofstream(path) << "name = \"" << name << "\"\nunits = \"m\"\n[recorded]\nset = \""
                      << (dir / (name + ".h5")).string() << "\"\n"
                      << tables;
  return path;
}

// An experiment's run on recorded plots: it ran (a finding is allowed), printed `text`, and its
// headline (in `out`) leads with `first_metric`.
void expect_judged(const testing::ToolResult& result, const std::string& text,
                   const std::filesystem::path& out, const std::string& first_metric) {
  ASSERT_TRUE(result.exit_code == 0 || result.exit_code == 7) << result.err;
  EXPECT_NE(result.out.find(text), std::string::npos) << result.out;
  EXPECT_EQ(nlohmann::json::parse(testing::slurp(out / "headline.json"))["metrics"][0]["name"],
            first_metric);
}

constexpr const char* kAirSurveillance = "configs/regimes/air_surveillance.toml";

// Polar recordings: σ_r and σ_θ, the wIMM and its nIMM baseline are learned from the plots alone,
// and imm-eval wimm judges them by the plots.
TEST_F(Tools, PolarRecordingsTrainAndEvaluateTheWimmWithoutTruth) {
  const std::filesystem::path polar =
      recorded_regime(root_, dir_.path(), "polar_rec", kAirSurveillance, 6, {"--no-truth"},
                      {"--sensor", "polar", "--scans", "60"},
                      "[sensor]\nkind = \"polar\"\nsigma = \"estimate\"\n"
                      "[splits]\ntraining = 2\nvalidation = 2\ntest = 2\n");
  const auto wrong_sensor =
      run_tool("imm-data",
               {"import", "--out", (dir_ / "p.h5").string(), (dir_ / "polar_rec").string()}, root_);
  EXPECT_EQ(wrong_sensor.exit_code, 2);
  EXPECT_NE(wrong_sensor.err.find("--sensor polar"), std::string::npos) << wrong_sensor.err;
  const auto trained = run_tool("imm-train",
                                {"wimm", "--config", "configs/wimm_tuned.toml", "--regime",
                                 polar.string(), "--out", (dir_ / "w.h5").string()},
                                root_);
  ASSERT_EQ(trained.exit_code, 0) << trained.err;
  // Its log states what it was judged by: the plots' excess NLL, not ratios of errors it has no
  // truth for (they once read "settled azimuth RMSE x0.0000").
  EXPECT_NE(trained.err.find("on the training recordings, no truth"), std::string::npos)
      << trained.err;
  EXPECT_EQ(trained.err.find("RMSE x"), std::string::npos) << trained.err;
  const auto metrics = nlohmann::json::parse(testing::slurp(dir_ / "w.metrics.json"));
  EXPECT_TRUE(metrics.contains("excess_nll")) << metrics.dump();
  EXPECT_FALSE(metrics.contains("azimuth_ratio_settled")) << metrics.dump();
  const auto inspected = nlohmann::json::parse(
      run_tool("imm-inspect", {(dir_ / "w.h5").string(), "--json"}, root_).out);
  EXPECT_EQ(inspected["attributes"]["training.trained_without_truth"], 1.0) << inspected.dump();
  // σ_r (100 m) and σ_θ (0.2°) learned from four windows of 60 plots.
  const auto& wimm = inspected["objects"]["/wimm"]["attributes"];
  EXPECT_NE(wimm["range_sigma"].get<double>(), 100.0);
  EXPECT_NEAR(wimm["range_sigma"].get<double>(), 100.0, 20.0) << wimm.dump();
  EXPECT_NEAR(wimm["azimuth_sigma"].get<double>() * 180.0 / 3.14159265358979, 0.2, 0.04)
      << wimm.dump();
  const auto baseline = run_tool("imm-train",
                                 {"baseline", "--config", "configs/wimm_tuned.toml", "--regime",
                                  polar.string(), "--out", (dir_ / "n.h5").string()},
                                 root_);
  ASSERT_EQ(baseline.exit_code, 0) << baseline.err;
  expect_judged(
      run_tool("imm-eval",
               {"wimm", "--model", (dir_ / "w.h5").string(), "--out", (dir_ / "we").string()},
               root_),
      "wIMM − this NLL per plot", dir_ / "we", "predictive_nll");
  // Recordings with their truth: the wIMM's usual errors, and the plots' prediction beside them.
  const std::filesystem::path with_truth =
      recorded_regime(root_, dir_.path(), "polar_truth", kAirSurveillance, 6, {"--seed", "5"},
                      {"--sensor", "polar", "--scans", "60"},
                      "[sensor]\nkind = \"polar\"\nrange_sigma = 100.0\nazimuth_sigma_deg = 0.2\n"
                      "[splits]\ntraining = 2\nvalidation = 2\ntest = 2\n");
  const auto judged = run_tool("imm-eval",
                               {"wimm", "--model", (dir_ / "w.h5").string(), "--regime",
                                with_truth.string(), "--out", (dir_ / "wt").string()},
                               root_);
  expect_judged(judged, "The recorded plots' prediction", dir_ / "wt",
                "az_rmse_settled all tracks");
  EXPECT_NE(judged.out.find("az settled"), std::string::npos) << judged.out;
}

// A range sensor's recordings (z1, z2): the FIMM, through the TSK model fitted to the sensor's
// calibration samples, and the IMM are judged by the plots; the TSK trains from the calibration
// samples, but the FIMM's transitions from sojourns need the tracks' truth and are refused.
TEST_F(Tools, RangeSensorRecordingsEvaluateTheFimmByTheirPlots) {
  const std::string sensor =
      "[sensor]\nkind = \"range_sensor\"\nsigma = [0.5, 0.5]\nknee = 40.0\nsoftness = 30.0\n"
      "[sensor.calibration]\nbox = [[-6.0, 1.0], [6.0, 100.0]]\nsamples = 8000\n"
      "noise_sigma = 0.05\n";
  const std::string splits = "[splits]\ntraining = 1\nvalidation = 1\ntest = 10\n";
  std::ofstream(dir_ / "cut_in.toml")
      << "name = \"cut_in\"\nunits = \"m\"\nsample_period = 0.1\nscans = 200\n"
      << sensor
      << "[start]\nposition = [3.5, 0.0]\nvelocity = [0.0, 3.0]\n[[cases]]\nname = \"R\"\n"
         "[[cases.segments]]\nkind = \"lane_change\"\nstart = 1.0\nend = 4.0\noffset = 3.5\n";
  const std::string cut_in = (dir_ / "cut_in.toml").string();
  const std::filesystem::path recorded =
      recorded_regime(root_, dir_.path(), "cut_in_rec", cut_in, 12, {"--no-truth"},
                      {"--sensor", "range_sensor"}, sensor + splits);
  EXPECT_EQ(testing::lines_of(testing::slurp(dir_ / "cut_in_rec" / "track_000.csv"))[0], "t,z1,z2");
  expect_judged(run_tool("imm-eval",
                         {"fimm", "--model", "models/tsk_range_sensor.h5", "--regime",
                          recorded.string(), "--out", (dir_ / "fe").string()},
                         root_),
                "FIMM (EKF) − this NLL per plot", dir_ / "fe", "predictive_nll");
  // The same plots with their truth: the usual errors, and the plots' prediction beside them.
  const std::filesystem::path with_truth =
      recorded_regime(root_, dir_.path(), "cut_in_truth", cut_in, 12, {},
                      {"--sensor", "range_sensor"}, sensor + splits);
  expect_judged(run_tool("imm-eval",
                         {"fimm", "--model", "models/tsk_range_sensor.h5", "--regime",
                          with_truth.string(), "--out", (dir_ / "ft").string()},
                         root_),
                "The recorded plots' prediction", dir_ / "ft", "fimm_mse all tracks");
  const auto refused = run_tool("imm-train",
                                {"tsk", "--config", "configs/tsk_range_sensor.toml", "--regime",
                                 recorded.string(), "--out", (dir_ / "m.h5").string()},
                                root_);
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("recorded.truth"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("sojourns"), std::string::npos) << refused.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "m.h5"));
}

// Truth for some recordings only: the test split takes them first; every test track is judged by
// its plots, and --truth-tracks judges those with truth by their errors.
TEST_F(Tools, PartialTruthJudgesAllByThePlotsAndTheTruthTracksByTheirErrors) {
  for (const auto& [folder, seed, truth] :
       {std::tuple{"with", "1", true}, std::tuple{"without", "2", false}}) {
    std::vector<std::string> args = {"export",  "--regime",  kTable3,
                                     "--count", "4",         "--seed",
                                     seed,      "--out-dir", (dir_ / folder).string()};
    if (!truth) args.emplace_back("--no-truth");
    ASSERT_EQ(run_tool("imm-data", args, root_).exit_code, 0);
  }
  const auto imported = run_tool("imm-data",
                                 {"import", "--units", "km", "--out", (dir_ / "p.h5").string(),
                                  (dir_ / "with").string(), (dir_ / "without").string()},
                                 root_);
  ASSERT_EQ(imported.exit_code, 0) << imported.err;
  EXPECT_NE(imported.out.find("with truth for 4 of 8 recordings"), std::string::npos)
      << imported.out;
  std::ofstream(dir_ / "partial.toml")
      << "name = \"partial\"\nunits = \"km\"\n[recorded]\nset = \"" << (dir_ / "p.h5").string()
      << "\"\nacceleration = [0.01, 0.05]\n[sensor]\nkind = \"cartesian\"\nsigma = [0.5, 0.5]\n"
         "[splits]\ntraining = 2\nvalidation = 1\ntest = 5\n";
  const auto trained =
      run_tool("imm-train",
               {"baseline", "--config", "configs/ga_fuzzy_imm_tuned.toml", "--regime",
                (dir_ / "partial.toml").string(), "--out", (dir_ / "b.h5").string()},
               root_);
  ASSERT_EQ(trained.exit_code, 0) << trained.err;
  EXPECT_NE(trained.err.find("excess NLL per plot"), std::string::npos) << trained.err;
  expect_judged(
      run_tool("imm-eval",
               {"ga-imm", "--model", (dir_ / "b.h5").string(), "--out", (dir_ / "g").string()},
               root_),
      "4 of 5 test tracks have truth", dir_ / "g", "predictive_nll");
  const auto errors = run_tool("imm-eval",
                               {"ga-imm", "--model", (dir_ / "b.h5").string(), "--truth-tracks",
                                "--out", (dir_ / "t").string()},
                               root_);
  expect_judged(errors, "the 4 of 5 test tracks with truth", dir_ / "t", "zeta_p");
  EXPECT_NE(errors.out.find("The recorded plots' prediction"), std::string::npos) << errors.out;
  EXPECT_EQ(nlohmann::json::parse(testing::slurp(dir_ / "t" / "headline.json"))["runs"], 4);
  // The FCM-IMM and the input estimator learn from the plots (two training recordings have no
  // truth) and on the truth tracks report the plots' prediction beside the errors.
  const auto fcm = run_tool("imm-train",
                            {"fcm", "--config", "configs/fcm_imm.toml", "--regime",
                             (dir_ / "partial.toml").string(), "--out", (dir_ / "f.h5").string()},
                            root_);
  ASSERT_EQ(fcm.exit_code, 0) << fcm.err;
  const auto mlp =
      run_tool("imm-train",
               {"mlp", "--config", "configs/mlp_input_estimator_tuned.toml", "--regime",
                (dir_ / "partial.toml").string(), "--out", (dir_ / "i.h5").string()},
               root_);
  ASSERT_EQ(mlp.exit_code, 0) << mlp.err;
  for (const auto& [experiment, model] :
       {std::pair{"fcm-imm", "f.h5"}, std::pair{"input-estimator", "i.h5"}}) {
    const auto judged = run_tool("imm-eval",
                                 {experiment, "--model", (dir_ / model).string(), "--truth-tracks",
                                  "--out", (dir_ / experiment).string()},
                                 root_);
    ASSERT_TRUE(judged.exit_code == 0 || judged.exit_code == 7) << judged.err;
    EXPECT_NE(judged.out.find("The recorded plots' prediction"), std::string::npos) << judged.out;
  }
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
