// SPDX-License-Identifier: Apache-2.0
// End-to-end: imm-train then imm-eval, kind by kind: a model trained, frozen or imported, then
// evaluated.

#include <gtest/gtest.h>

#include <map>
#include <nlohmann/json.hpp>

#include "testing/regime_files.hpp"
#include "testing/shipped_tracker.hpp"
#include "testing/tools_fixture.hpp"

// The fixture and its helpers are imm::testing's (testing/tools_fixture.hpp).
namespace imm::testing {
namespace {

TEST_F(Tools, ImmTrainFreezeNamesTheBadKey) {
  testing::write_text(dir_ / "bad.toml",
                      testing::slurp(config("configs/track/cv3_imm.toml")) +
                          "\n[[modes]]\nname = \"x\"\nmotion = \"cv\"\nprocess_noise = -5\n");
  const auto result = run_tool(
      "imm-train",
      {"freeze", "--config", (dir_ / "bad.toml").string(), "--out", (dir_ / "m.h5").string()},
      root_);
  EXPECT_EQ(result.exit_code, 2);
  // Four modes but a 3x3 transition: the first invalid key is reported.
  EXPECT_NE(result.err.find("bad.toml: key 'transition'"), std::string::npos) << result.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "m.h5"));
}

TEST_F(Tools, PlainImmEvaluationWritesMetricsAndBeatsEachModeAlone) {
  const auto model = dir_ / "models" / "cv3_imm.h5";
  freeze_cv3(model);
  const auto out = dir_ / "report";
  const auto result = run_tool(
      "imm-eval",
      {"plain-imm", "--models", (dir_ / "models").string(), "--runs", "30", "--out", out.string()},
      root_);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto metrics = evaluation_results(out);
  ASSERT_EQ(metrics["rows"].size(), 4u);
  const double imm_zeta_p = metrics["rows"][0]["zeta_p"];
  for (std::size_t i = 1; i < 4; ++i) {
    EXPECT_LT(imm_zeta_p, metrics["rows"][i]["zeta_p"].get<double>())
        << metrics["rows"][i]["filter"];
  }
  EXPECT_TRUE(std::filesystem::exists(out / "normalized_position_error.csv"));
  EXPECT_TRUE(std::filesystem::exists(out / "mode_probabilities.csv"));
  // The regression gate compares accuracy and consistency: ζ_p, ζ_v and the NEES log ratio.
  const auto headline = nlohmann::json::parse(testing::slurp(out / "headline.json"));
  std::vector<std::string> names;
  for (const auto& m : headline["metrics"]) names.push_back(m["name"]);
  EXPECT_EQ(names, (std::vector<std::string>{"zeta_p", "zeta_v", "position_nees_log_ratio"}));
  EXPECT_GE(headline["metrics"][2]["value"].get<double>(), 0.0);

  // metrics.json names the model it evaluated, byte for byte.
  const auto document = nlohmann::json::parse(testing::slurp(out / "metrics.json"));
  const auto& evaluated = document["models"][0];
  EXPECT_EQ(evaluated["role"], "evaluated");
  EXPECT_EQ(evaluated["sha256"],
            run_tool("/usr/bin/sha256sum", {model.string()}, {}).out.substr(0, 64));
  EXPECT_EQ(evaluated["kind"], "plain_imm");
  EXPECT_EQ(document["runs"], 30);
  // report.md: readable alone — the command, the model with its trainer version and digest, the
  // definitions with units, then the tables.
  const std::string report = testing::slurp(out / "report.md");
  for (const std::string& expected :
       {std::string("# imm-eval plain-imm"), std::string("--runs 30"), std::string("## Models"),
        evaluated["trainer_version"].get<std::string>(),
        evaluated["sha256"].get<std::string>().substr(0, 16), std::string("| ζ_p | 1 |"),
        std::string("| position RMSE | km |"), std::string("## Results"),
        std::string("IMM − this ζ_p [95 %]")}) {
    EXPECT_NE(report.find(expected), std::string::npos) << expected << "\n" << report;
  }
  // The plot scripts name their files relative to the folder: moved elsewhere, a script still
  // draws its PNG there, with the runs and the model named.
  const std::string script = testing::slurp(out / "normalized_position_error.gp");
  EXPECT_EQ(script.find(out.string()), std::string::npos) << script;
  EXPECT_NE(script.find("30 runs, seed 1, model cv3_imm.h5"), std::string::npos) << script;
  const auto moved = dir_ / "moved";
  std::filesystem::rename(out, moved);
  std::filesystem::remove(moved / "normalized_position_error.png");
  // gnuplot is a dependency (scripts/install-deps.sh: gnuplot-nox).
  const auto gnuplot = run_tool("/usr/bin/gnuplot", {"normalized_position_error.gp"}, moved);
  EXPECT_EQ(gnuplot.exit_code, 0) << gnuplot.err;
  EXPECT_TRUE(std::filesystem::exists(moved / "normalized_position_error.png"));
}

// A real kill (SIGKILL) in the middle of training, then --resume: the same model as an
// uninterrupted run.
TEST_F(Tools, GaImmEvaluationReportsTable3ForEveryFilter) {
  const auto out = dir_ / "ga-imm";
  const auto result = run_tool("imm-eval",
                               {"ga-imm", "--models", config("models").string(), "--regime",
                                kTable3, "--runs", "10", "--out", out.string()},
                               root_);
  ASSERT_TRUE(result.exit_code == 0 || result.exit_code == 5 || result.exit_code == 7)
      << result.err;
  EXPECT_NE(result.out.find("| GA-IMM-paper "), std::string::npos) << result.out;
  const auto metrics = evaluation_results(out);
  for (const char* name : {"AIMM3", "AIMM5", "AIMM-tuned", "IMM-tuned", "GA-IMM-paper", "GA-IMM"}) {
    ASSERT_TRUE(metrics.contains(name)) << name;
    EXPECT_GT(metrics[name]["zeta_p"].get<double>(), 0.0);
    EXPECT_GT(metrics[name]["zeta_v"].get<double>(), 0.0);
  }
  const auto details = nlohmann::json::parse(testing::slurp(out / "details.json"));
  EXPECT_TRUE(details["process_noise_spread"]["GA-IMM"].contains("u0.1"));
  EXPECT_TRUE(std::filesystem::exists(out / "normalized_position_error.csv"));
  EXPECT_TRUE(std::filesystem::exists(out / "mode_probabilities_ga_imm.csv"));
}

// A regime no code has seen, written here: the GA's training regime with its accelerations
// multiplied by 3 at T = 2 s, and the input estimator's at T = 2 s. Each trains, records the
// regime, and is evaluated on it beside its baselines, with no change anywhere else.
TEST_F(Tools, GaAndInputEstimatorTrainAndEvaluateOnARegimeWrittenInTheTest) {
  const auto ga_regime =
      testing::write_preset_variant(dir_, "ga_imm_training",
                                    {{"name = \"ga_imm_training\"", "name = \"ga_times_three\""},
                                     {"sample_period = 1.0", "sample_period = 2.0"},
                                     {"scans = 160", "scans = 60"},
                                     {"magnitude = [0.001, 0.1]", "magnitude = [0.003, 0.3]"},
                                     {"training = 9", "training = 2"},
                                     {"validation = 6", "validation = 1"},
                                     {"test = 100", "test = 6"}});
  std::string ga = testing::slurp(config("configs/ga_fuzzy_imm.toml"));
  ga.replace(ga.find("population = 500"), 16, "population = 20");
  ga.replace(ga.find("generations = 100"), 17, "generations = 3");
  testing::write_text(dir_ / "ga.toml", ga);
  const auto models = dir_ / "models";
  const auto trained = train("ga", dir_ / "ga.toml", ga_regime, models / "ga.h5");
  ASSERT_EQ(trained.exit_code, 0) << trained.err;
  EXPECT_NE(trained.err.find("levels [0.003, 0.03, 0.3]"), std::string::npos) << trained.err;
  const auto ga_report = run_tool("imm-eval",
                                  {"ga-imm", "--models", models.string(), "--model", "ga", "--out",
                                   (dir_ / "ga-report").string()},
                                  root_);
  ASSERT_TRUE(ga_report.exit_code == 0 || ga_report.exit_code == 5 || ga_report.exit_code == 7)
      << ga_report.err;
  EXPECT_NE(ga_report.out.find("regime ga_times_three"), std::string::npos) << ga_report.out;
  EXPECT_NE(ga_report.out.find("the model's own"), std::string::npos) << ga_report.out;
  for (const char* filter : {"| AIMM3 ", "| AIMM-tuned ", "| IMM-tuned ", "| GA-IMM "}) {
    EXPECT_NE(ga_report.out.find(filter), std::string::npos) << filter;
  }
  // The paper's tables are built for T = 1 s: left out, with the reason.
  EXPECT_NE(ga_report.out.find("GA-IMM-paper left out"), std::string::npos) << ga_report.out;
  // The T = 2 s model on the T = 1 s paper scenario is refused, naming the field.
  const auto refused = run_tool("imm-eval",
                                {"ga-imm", "--models", models.string(), "--model", "ga", "--regime",
                                 kTable3, "--out", (dir_ / "refused").string()},
                                root_);
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("sample_period"), std::string::npos) << refused.err;
  // Both files named: the model's and the regime's.
  EXPECT_NE(refused.err.find("ga.h5"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find(kTable3), std::string::npos) << refused.err;

  const auto mlp_regime = testing::write_preset_variant(
      dir_, "input_estimator_training",
      {{"sample_period = 1.0", "sample_period = 2.0"}, {"test = 100", "test = 4"}});
  std::string mlp = testing::slurp(config("configs/mlp_input_estimator.toml"));
  for (std::size_t at = mlp.find("epochs = 3000"); at != std::string::npos;
       at = mlp.find("epochs = 3000")) {
    mlp.replace(at, 13, "epochs = 200");
  }
  mlp.replace(mlp.find("max_validation_rmse = 0.3"), 25, "max_validation_rmse = 5.0");
  testing::write_text(dir_ / "mlp.toml", mlp);
  const auto mlp_trained = train("mlp", dir_ / "mlp.toml", mlp_regime, models / "mlp.h5");
  ASSERT_EQ(mlp_trained.exit_code, 0) << mlp_trained.err;
  const auto mlp_report = run_tool("imm-eval",
                                   {"input-estimator", "--models", models.string(), "--model",
                                    "mlp", "--out", (dir_ / "mlp-report").string()},
                                   root_);
  ASSERT_TRUE(mlp_report.exit_code == 0 || mlp_report.exit_code == 5 || mlp_report.exit_code == 7)
      << mlp_report.err;
  EXPECT_NE(mlp_report.out.find("the model's own"), std::string::npos) << mlp_report.out;
  EXPECT_NE(mlp_report.out.find("| all tracks "), std::string::npos) << mlp_report.out;
  // Beside the CV KF, the tuned classical filter, with a verdict and an interval in every cell.
  EXPECT_NE(mlp_report.out.find("IMM-tuned: q "), std::string::npos) << mlp_report.out;
  EXPECT_NE(mlp_report.out.find("/s²)², stay "), std::string::npos) << mlp_report.out;
  EXPECT_NE(mlp_report.out.find("Against the tuned classical filter"), std::string::npos);
  const auto metrics = nlohmann::json::parse(testing::slurp(dir_ / "mlp-report/metrics.json"));
  const auto& row = metrics.at("results").at("rows").at(0);
  const std::string verdict = row.at("versus_imm_tuned");
  EXPECT_TRUE(verdict == "beats" || verdict == "loses to" || verdict == "mixed" ||
              verdict == "ties")
      << verdict;
  const auto& interval = row.at("corrected_minus_imm_tuned").at("position_mse");
  EXPECT_LE(interval.at(1).get<double>(), interval.at(0).get<double>());
  EXPECT_LE(interval.at(0).get<double>(), interval.at(2).get<double>());
  // Beside it, the 2-D classical bar (the regime's tuned CV/CA/CT IMM) on the same tracks.
  EXPECT_NE(mlp_report.out.find("Against CT-IMM-tuned (the classical bar"), std::string::npos)
      << mlp_report.out;
  const std::string bar_verdict = metrics.at("results").at("versus_classical_bar").at("verdict");
  if (mlp_report.exit_code != 5) {  // gates passed: exit 7 exactly when there is a finding
    EXPECT_EQ(mlp_report.exit_code == 7, verdict != "beats" || bar_verdict != "beats")
        << mlp_report.out;
  }
  // The regression gate also holds back a less consistent candidate: one NEES figure per case.
  EXPECT_EQ(consistency_headlines(dir_ / "mlp-report"),
            static_cast<int>(metrics.at("results").at("rows").size()));
}

// The regime's tracker on a regime no code has seen (the GA's levels ×3 at T = 2 s): its tuned
// baseline (`imm-train baseline`), a GA-fuzzy IMM learned on top of it, both ranked on the test
// split by `imm-eval rank`, and the winner written as the tracker file a tracking application
// loads — by the stated rule, with its reason and intervals.
TEST_F(Tools, TheRegimesTrackerIsChosenOnARegimeWrittenInTheTest) {
  const auto regime =
      testing::write_preset_variant(dir_, "ga_imm_training",
                                    {{"name = \"ga_imm_training\"", "name = \"ga_times_three\""},
                                     {"sample_period = 1.0", "sample_period = 2.0"},
                                     {"scans = 160", "scans = 60"},
                                     {"magnitude = [0.001, 0.1]", "magnitude = [0.003, 0.3]"},
                                     {"training = 9", "training = 3"},
                                     {"validation = 6", "validation = 2"},
                                     {"test = 100", "test = 12"}});
  std::string tuned = testing::slurp(config("configs/ga_fuzzy_imm_tuned.toml"));
  tuned.replace(tuned.find("population = 500"), 16, "population = 20");
  tuned.replace(tuned.find("generations = 100"), 17, "generations = 3");
  testing::write_text(dir_ / "tuned.toml", tuned);
  const auto models = dir_ / "models";
  const auto baseline =
      run_tool("imm-train",
               {"baseline", "--config", (dir_ / "tuned.toml").string(), "--regime", regime.string(),
                "--out", (models / "baseline.h5").string()},
               root_);
  ASSERT_EQ(baseline.exit_code, 0) << baseline.err;
  EXPECT_NE(baseline.err.find("tuned on the training split"), std::string::npos) << baseline.err;
  const auto trained = train("ga", dir_ / "tuned.toml", regime, models / "ga.h5");
  ASSERT_EQ(trained.exit_code, 0) << trained.err;

  // The GA model's own experiment, whose gates decide whether it may be the tracker at all.
  const auto evaluated = run_tool("imm-eval",
                                  {"ga-imm", "--models", models.string(), "--model", "ga", "--out",
                                   (dir_ / "ga-eval").string()},
                                  root_);
  ASSERT_TRUE(evaluated.exit_code == 0 || evaluated.exit_code == 5 || evaluated.exit_code == 7)
      << evaluated.err;
  const bool gates_passed = evaluated.exit_code != 5;

  const auto tracker = dir_ / "shipped" / "ga_times_three" / "tracker.h5";
  const auto ranked =
      run_tool("imm-eval",
               {"rank", "--baseline", (models / "baseline.h5").string(), "--candidates",
                (models / "ga.h5").string(), "--evaluations", (dir_ / "ga-eval").string(), "--out",
                (dir_ / "rank").string(), "--ship", tracker.string()},
               root_);
  ASSERT_TRUE(ranked.exit_code == 0 || ranked.exit_code == 7) << ranked.err;
  EXPECT_NE(ranked.out.find("regime ga_times_three test split"), std::string::npos) << ranked.out;
  EXPECT_NE(ranked.out.find("| baseline (the classical bar) "), std::string::npos) << ranked.out;
  const auto choice = nlohmann::json::parse(testing::slurp(dir_ / "rank" / "tracker.json"));
  ASSERT_EQ(choice["ranking"].size(), 2u);
  // The stated rule, checked from the reported intervals: the GA model is the tracker exactly when
  // it beats the baseline (better beyond the interval in one figure, worse in neither).
  nlohmann::json ga_row;
  for (const auto& row : choice["ranking"]) {
    if (row["filter"] == "ga") ga_row = row;
  }
  ASSERT_TRUE(ga_row.contains("versus_baseline")) << choice.dump();
  const auto& p = ga_row["versus_baseline"]["zeta_p"];
  const auto& v = ga_row["versus_baseline"]["zeta_v"];
  const bool better = p[2].get<double>() < 0 || v[2].get<double>() < 0;
  const bool worse = p[1].get<double>() > 0 || v[1].get<double>() > 0;
  EXPECT_EQ(choice["tracker"], better && !worse && gates_passed ? "ga" : "baseline")
      << choice.dump();
  EXPECT_EQ(ranked.exit_code == 7, !(better && !worse && gates_passed))
      << ranked.out;  // a finding otherwise
  EXPECT_EQ(ga_row["eligible"], gates_passed) << choice.dump();
  EXPECT_FALSE(choice["reason"].get<std::string>().empty());
  // The tracker file is the winner's with its calibration, and runs as any model file does.
  testing::expect_winner_with_calibration(tracker,
                                          models / (choice["tracker"].get<std::string>() + ".h5"));
  const auto inspected = run_tool("imm-inspect", {tracker.string()}, root_);
  EXPECT_EQ(inspected.exit_code, 0) << inspected.err;

  // Its own experiment's gates failed (the same evaluation, its verdict turned to FAILED): it is
  // held out whatever its figures, with the failure named; and with no evaluation of the file
  // given, it is held out as unchecked.
  std::filesystem::copy(dir_ / "ga-eval", dir_ / "ga-failed",
                        std::filesystem::copy_options::recursive);
  std::string report = testing::slurp(dir_ / "ga-failed" / "report.md");
  const auto gates = report.find("\nGates");
  ASSERT_NE(gates, std::string::npos) << report;
  const auto end = report.find('\n', gates + 1);
  const auto colon = report.rfind(": ", end);
  report.replace(colon, end - colon, ": FAILED\n  - GA-IMM is worse than AIMM3 (planted)");
  testing::write_text(dir_ / "ga-failed" / "report.md", report);
  for (const auto& [evaluations, standing] :
       std::vector<std::pair<std::vector<std::string>, std::string>>{
           {{"--evaluations", (dir_ / "ga-failed").string()}, "FAILED in "},
           {{}, "unchecked: no evaluation of this file given"}}) {
    std::vector<std::string> arguments{"rank",
                                       "--baseline",
                                       (models / "baseline.h5").string(),
                                       "--candidates",
                                       (models / "ga.h5").string(),
                                       "--out",
                                       (dir_ / "rank-held").string()};
    arguments.insert(arguments.end(), evaluations.begin(), evaluations.end());
    const auto held = run_tool("imm-eval", arguments, root_);
    EXPECT_EQ(held.exit_code, 7) << held.err;
    const auto json = nlohmann::json::parse(testing::slurp(dir_ / "rank-held" / "tracker.json"));
    EXPECT_EQ(json["tracker"], "baseline") << json.dump();
    for (const auto& row : json["ranking"]) {
      if (row["filter"] != "ga") continue;
      EXPECT_FALSE(row["eligible"].get<bool>());
      EXPECT_TRUE(row["own_gates"].get<std::string>().starts_with(standing)) << row.dump();
    }
    EXPECT_NE(held.out.find("ga is held out of the choice"), std::string::npos) << held.out;
  }
  EXPECT_NE(testing::slurp(dir_ / "rank" / "report.md").find("ga: "), std::string::npos);

  // A model of another regime is refused, naming it.
  const auto other = run_tool(
      "imm-eval",
      {"rank", "--baseline", (models / "baseline.h5").string(), "--candidates",
       (root_ / "models" / "ga_fuzzy_imm.h5").string(), "--out", (dir_ / "rank-other").string()},
      root_);
  EXPECT_EQ(other.exit_code, 2);
  EXPECT_NE(other.err.find("ga_fuzzy_imm.h5"), std::string::npos) << other.err;
  // An edited copy of the regime that keeps its name: the refusal says the text differs, and
  // which file.
  testing::write_text(dir_ / "edited.toml", "# edited\n" + testing::slurp(regime));
  const auto edited =
      run_tool("imm-eval",
               {"rank", "--baseline", (models / "baseline.h5").string(), "--candidates",
                (models / "ga.h5").string(), "--regime", (dir_ / "edited.toml").string(), "--out",
                (dir_ / "rank-edited").string()},
               root_);
  EXPECT_EQ(edited.exit_code, 2);
  EXPECT_NE(edited.err.find("another text of regime ga_times_three"), std::string::npos)
      << edited.err;
  EXPECT_NE(edited.err.find("edited.toml"), std::string::npos) << edited.err;

  // The classical CV/CA/CT IMM of the same regime, with no code for it: tuned by imm-train
  // baseline from its [classical] config; ranked beside the constant-q baseline, the better of the
  // two on the test tracks is the bar the GA model faces, and the other is never the tracker.
  const auto classical =
      train("baseline", config("configs/classical_imm.toml"), regime, models / "classical.h5");
  ASSERT_EQ(classical.exit_code, 0) << classical.err;
  EXPECT_NE(classical.err.find("the classical IMM tuned on the training split"), std::string::npos)
      << classical.err;
  const auto both = run_tool(
      "imm-eval",
      {"rank", "--baseline", (models / "baseline.h5").string(), (models / "classical.h5").string(),
       "--candidates", (models / "ga.h5").string(), "--out", (dir_ / "rank-two").string()},
      root_);
  ASSERT_TRUE(both.exit_code == 0 || both.exit_code == 7) << both.err;
  const auto two = nlohmann::json::parse(testing::slurp(dir_ / "rank-two" / "tracker.json"));
  ASSERT_EQ(two["ranking"].size(), 3u);
  std::map<std::string, double> sums;
  for (const auto& row : two["ranking"]) {
    sums[row["filter"]] = row["zeta_p"].get<double>() + row["zeta_v"].get<double>();
  }
  const std::string bar = sums["classical"] < sums["baseline"] ? "classical" : "baseline";
  EXPECT_EQ(two["bar"], bar) << two.dump();
  EXPECT_NE(both.out.find("The classical bar: " + bar), std::string::npos) << both.out;
  EXPECT_NE(two["tracker"], bar == "classical" ? "baseline" : "classical") << two.dump();
}

// A polar regime's tracker (a regime written in the test: air_surveillance, small, its sensor away
// from the origin): its tuned normal IMM (`imm-train baseline` with a wIMM config) and a wIMM
// learned on top of it, ranked on the test split by the Cartesian regimes' rule, the plots scored
// as positions around the sensor.

}  // namespace
}  // namespace imm::testing
