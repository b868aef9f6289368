// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "imm/pipeline/nightly.hpp"
#include "imm/support/config.hpp"
#include "nightly_trends.hpp"
#include "stage_cache.hpp"
#include "testing/config_error.hpp"
#include "testing/temp_dir.hpp"

namespace imm::pipeline {
namespace {

TEST(Nightly, PlanListsStagesInPipelineOrder) {
  const NightlyPlan plan = load_nightly_plan("configs/nightly.toml");
  ASSERT_GE(plan.stages.size(), 4u);
  std::vector<std::string> kinds;
  for (const auto& stage : plan.stages) kinds.push_back(stage.kind);
  EXPECT_TRUE(std::is_sorted(kinds.begin(), kinds.end(), [](const auto& a, const auto& b) {
    auto rank = [](const std::string& k) {
      return k == "data" ? 0 : k == "model" ? 1 : k == "track" ? 2 : k == "evaluation" ? 3 : 4;
    };
    return rank(a) < rank(b);
  }));
  EXPECT_EQ(plan.stages.front().executable, "imm-data");
}

TEST(Nightly, UnknownKeyInThePlanIsAnError) {
  const testing::TempDir dir;
  testing::write_text(
      dir / "n.toml",
      "[[models]]\nname = \"a\"\ncommand = \"freeze\"\nconfig = \"c\"\nout = \"models/o\"\n"
      "threads = 2\n");
  try {
    (void)load_nightly_plan(dir / "n.toml");
    FAIL();
  } catch (const support::ConfigError& error) {
    EXPECT_EQ(error.key(), "models[0].threads");
  }
}

TEST(Nightly, AnEvaluationMustNameAModelStage) {
  const testing::TempDir dir;
  testing::write_text(dir / "n.toml",
                      "[[models]]\nname = \"a\"\ncommand = \"freeze\"\nconfig = \"c\"\n"
                      "out = \"models/a.h5\"\n[[evaluations]]\nexperiment = \"plain-imm\"\n"
                      "model = \"b\"\nout = \"r/\"\n");
  try {
    (void)load_nightly_plan(dir / "n.toml");
    FAIL();
  } catch (const support::ConfigError& error) {
    EXPECT_EQ(error.key(), "evaluations[0].model");
  }
}

TEST(Nightly, ATrackerRanksItsModelsFilesAndShipsIntoTheRegistry) {
  const testing::TempDir dir;
  const std::string models =
      "[[models]]\nname = \"base\"\ncommand = \"baseline\"\nconfig = \"c\"\n"
      "out = \"models/base.h5\"\n[[models]]\nname = \"ga\"\ncommand = \"ga\"\nconfig = \"c\"\n"
      "out = \"models/ga.h5\"\n[[evaluations]]\nexperiment = \"ga-imm\"\nmodel = \"ga\"\n"
      "out = \"reports/ga/\"\n";
  testing::write_text(dir / "n.toml", models +
                                          "[[trackers]]\nname = \"r\"\nbaseline = \"base\"\n"
                                          "candidates = [\"ga\"]\nout = \"models/r/tracker.h5\"\n"
                                          "report = \"reports/r/\"\nruns = 20\n");
  const NightlyPlan plan = load_nightly_plan(dir / "n.toml");
  const NightlyStage& tracker = plan.stages.back();
  EXPECT_EQ(tracker.kind, "tracker");
  EXPECT_EQ(tracker.executable, "imm-eval");
  EXPECT_EQ(tracker.arguments,
            (std::vector<std::string>{"rank", "--baseline", "models/base.h5", "--candidates",
                                      "models/ga.h5", "--evaluations", "reports/ga/",
                                      "reports/ga/shipped", "--out", "reports/r/", "--runs", "20",
                                      "--ship", "models/r/tracker.h5"}));
  EXPECT_EQ(tracker.out_argument, tracker.arguments.size() - 1);

  for (const auto& [tracker_text, key] : std::vector<std::pair<std::string, std::string>>{
           {"baseline = \"none\"\ncandidates = [\"ga\"]\nout = \"models/t.h5\"\n",
            "trackers[0].baseline"},
           {"baseline = \"base\"\ncandidates = [\"ga\", \"x\"]\nout = \"models/t.h5\"\n",
            "trackers[0].candidates"},
           {"baseline = \"base\"\ncandidates = []\nout = \"models/t.h5\"\n",
            "trackers[0].candidates"},
           {"baseline = \"base\"\ncandidates = [\"ga\"]\nout = \"elsewhere/t.h5\"\n",
            "trackers[0].out"}}) {
    testing::write_text(dir / "bad.toml",
                        models + "[[trackers]]\nname = \"r\"\nreport = \"x/\"\n" + tracker_text);
    try {
      (void)load_nightly_plan(dir / "bad.toml");
      ADD_FAILURE() << tracker_text;
    } catch (const support::ConfigError& error) {
      EXPECT_EQ(error.key(), key) << tracker_text;
    }
  }
}

TEST(Nightly, AModelMustBeWrittenInsideTheRegistry) {
  EXPECT_EQ(
      testing::config_error_key("[[models]]\nname = \"a\"\ncommand = \"freeze\"\nconfig = \"c\"\n"
                                "out = \"elsewhere/a.h5\"\n",
                                [](const auto& path) { return load_nightly_plan(path); }),
      "models[0].out");
}

// A model's name becomes its registry entry's: it must stay one path component.
TEST(Nightly, AModelNameThatCouldLeaveTheRegistryIsAnError) {
  EXPECT_EQ(testing::config_error_key(
                "[[models]]\nname = \"../x\"\ncommand = \"freeze\"\nconfig = \"c\"\n"
                "out = \"models/o.h5\"\n",
                [](const auto& path) { return load_nightly_plan(path); }),
            "models[0].name");
}

// The regression gate's practical margins: the shipped plan states one for every metric and one
// for the consistency log ratios, each with its reason; a margin without a reason, or negative,
// is refused naming the field.
TEST(Nightly, RegressionMarginsCarryTheirReasons) {
  const NightlyPlan plan = load_nightly_plan("configs/nightly.toml");
  ASSERT_GE(plan.margins.size(), 2u);
  EXPECT_EQ(plan.margins[0].metric, "");
  EXPECT_EQ(plan.margins[0].arguments(), (std::vector<std::string>{"--relative-margin", "0.001"}));
  for (const auto& margin : plan.margins) EXPECT_GT(margin.reason.size(), 40u) << margin.metric;
  const std::string model =
      "[[models]]\nname = \"a\"\ncommand = \"freeze\"\nconfig = \"c\"\nout = \"models/a.h5\"\n";
  const auto load = [](const auto& path) { return load_nightly_plan(path); };
  EXPECT_EQ(testing::config_error_key("[regression]\nrelative_margin = 0.01\n" + model, load),
            "regression.reason");
  EXPECT_EQ(testing::config_error_key(
                "[regression]\nrelative_margin = -0.01\nreason = \"why\"\n" + model, load),
            "regression.relative_margin");
  EXPECT_EQ(testing::config_error_key("[regression]\nreason = \"why\"\n" + model, load),
            "regression.relative_margin");
  EXPECT_EQ(testing::config_error_key("[regression]\nrelative_margin = 0.01\nreason = \"why\"\n"
                                      "[[regression.margins]]\nabsolute_margin = 1.0\n"
                                      "reason = \"why\"\n" +
                                          model,
                                      load),
            "regression.margins[0].metric");
}

TEST(Nightly, KnownFailuresCarryTheirReasons) {
  const std::string plan =
      "[[models]]\nname = \"a\"\ncommand = \"freeze\"\nconfig = \"c\"\nout = "
      "\"models/a.h5\"\n[[evaluations]]\nexperiment = \"plain-imm\"\nmodel = \"a\"\nout = "
      "\"r\"\n[[evaluations.known_failures]]\ngate = \"is above KF's\"\n";
  const auto load = [](const auto& path) { return load_nightly_plan(path); };
  EXPECT_EQ(testing::config_error_key(plan, load), "evaluations[0].known_failures[0].reason");
  EXPECT_EQ(testing::config_error_key(plan + "reason = \" \"\n", load),
            "evaluations[0].known_failures[0].reason");
  EXPECT_EQ(testing::config_error_key(plan + "reason = \"why\"\ngait = \"x\"\n", load),
            "evaluations[0].known_failures[0].gait");
  const testing::TempDir dir;
  std::ofstream(dir / "plan.toml") << plan << "reason = \"measured: the onset\"\n";
  const NightlyPlan loaded = load_nightly_plan(dir / "plan.toml");
  const auto evaluation = loaded.evaluations_of("a");
  ASSERT_EQ(evaluation.size(), 1u);
  ASSERT_EQ(evaluation[0]->known_failures.size(), 1u);
  EXPECT_EQ(evaluation[0]->known_failures[0].gate, "is above KF's");
  EXPECT_EQ(evaluation[0]->known_failures[0].reason, "measured: the onset");
  // The shipped plan's known failures say why, at length.
  for (const auto& stage : load_nightly_plan("configs/nightly.toml").stages) {
    for (const auto& known : stage.known_failures) EXPECT_GT(known.reason.size(), 80u);
  }
}

// Every stage digest includes the project's shared libraries the tools load (the runtime, when it
// is built shared): a rebuilt runtime reruns the stages.
TEST(Nightly, TheStageDigestIncludesTheSharedRuntime) {
  const auto libraries = project_libraries();
#ifdef IMM_RUNTIME_STATIC_DEFINE
  EXPECT_TRUE(libraries.empty());
#else
  ASSERT_FALSE(libraries.empty());
  EXPECT_TRUE(std::any_of(libraries.begin(), libraries.end(), [](const auto& library) {
    return library.filename().string().starts_with("libimmruntime.so");
  }));
#endif
}

// The recorded regime's data: an export without truth, then an import of its folder, both imm-data
// command lines; and the digests that decide whether a stage reruns follow the recordings an import
// reads and the track set a recorded regime names.
TEST(Nightly, RecordedDataStagesExportThenImportAndTheirDeclaredInputsAreDigested) {
  const NightlyPlan plan = load_nightly_plan("configs/nightly.toml");
  const NightlyStage* exported = nullptr;
  const NightlyStage* imported = nullptr;
  for (const auto& stage : plan.stages) {
    if (stage.kind != "data" || stage.arguments.empty()) continue;
    if (stage.arguments[0] == "export") exported = &stage;
    if (stage.arguments[0] == "import") imported = &stage;
  }
  ASSERT_NE(exported, nullptr);
  ASSERT_NE(imported, nullptr);
  const auto has = [](const NightlyStage& s, const std::string& a) {
    return std::find(s.arguments.begin(), s.arguments.end(), a) != s.arguments.end();
  };
  EXPECT_TRUE(has(*exported, "--no-truth"));
  EXPECT_TRUE(has(*exported, "--out-dir"));
  EXPECT_TRUE(has(*imported, exported->out.string()));  // the import reads the export's folder
  EXPECT_LT(exported - plan.stages.data(), imported - plan.stages.data());

  testing::TempDir dir;
  const auto folder = dir.path() / "recordings";
  std::filesystem::create_directories(folder);
  std::ofstream(folder / "a.csv") << "t,zx,zy\n0,1,2\n";
  // The plan declares what each stage reads: the import its recordings, the export its regime.
  const auto declares = [](const NightlyStage& s, StageInput::Kind kind, const std::string& path) {
    return std::any_of(s.inputs.begin(), s.inputs.end(), [&](const StageInput& input) {
      return input.kind == kind && input.path == path;
    });
  };
  EXPECT_TRUE(declares(*imported, StageInput::Kind::kRecordings, exported->out.string()));
  const auto regime = std::find(exported->arguments.begin(), exported->arguments.end(), "--regime");
  ASSERT_NE(regime, exported->arguments.end());
  EXPECT_TRUE(declares(*exported, StageInput::Kind::kFile, *(regime + 1)));
  EXPECT_EQ(imported->outputs, std::vector<std::filesystem::path>{imported->out});

  NightlyStage import = *imported;
  import.arguments = {"import", "--out", (dir.path() / "set.h5").string(), folder.string()};
  import.inputs = {{ StageInput::Kind::kRecordings, folder }};
  const auto tool = std::filesystem::path("configs/nightly.toml");  // any file stands for the tool
  Digests digests;
  const std::string before = inputs_digest(import, tool, digests);
  std::ofstream(folder / "a.csv", std::ios::app) << "1,1,2\n";
  Digests fresh;
  EXPECT_NE(inputs_digest(import, tool, fresh), before);

  // A model stage naming a recorded regime depends on its set.
  std::ofstream(dir.path() / "set.h5") << "one";
  std::ofstream(dir.path() / "recorded.toml")
      << "name = \"r\"\n[recorded]\nset = \"" << (dir.path() / "set.h5").string() << "\"\n";
  NightlyStage model;
  model.kind = "model";
  model.arguments = {"baseline", "--regime", (dir.path() / "recorded.toml").string()};
  model.inputs = {{StageInput::Kind::kFile, dir.path() / "recorded.toml"}};
  Digests first;
  const std::string with_one = inputs_digest(model, tool, first);
  std::ofstream(dir.path() / "set.h5") << "two";
  Digests second;
  const std::string with_two = inputs_digest(model, tool, second);
  EXPECT_NE(with_two, with_one);

  // Only what is declared is read: a file an argument names but no input declares is a text.
  std::ofstream(dir.path() / "notes.txt") << "one";
  model.arguments.push_back((dir.path() / "notes.txt").string());
  Digests third;
  const std::string with_notes = inputs_digest(model, tool, third);
  std::ofstream(dir.path() / "notes.txt") << "two";
  Digests fourth;
  EXPECT_EQ(inputs_digest(model, tool, fourth), with_notes);
}

TEST(Nightly, EvaluationsFollowTheirModel) {
  const NightlyPlan plan = load_nightly_plan("configs/nightly.toml");
  for (const auto& stage : plan.stages) {
    if (stage.kind != "model") continue;
    for (const NightlyStage* e : plan.evaluations_of(stage.name)) {
      ASSERT_TRUE(e->model_argument.has_value());
      EXPECT_EQ(e->arguments[*e->model_argument], stage.out.string());
    }
  }
}

// Every regime beyond the papers (configs/regimes/*.toml) has its tracker stage: the filter a
// tracking application loads for it, chosen every night among its models and its tuned baseline.
TEST(Nightly, EveryShippedRegimeHasATracker) {
  const NightlyPlan plan = load_nightly_plan("configs/nightly.toml");
  std::set<std::string> trackers;
  for (const auto& stage : plan.stages) {
    if (stage.kind == "tracker") trackers.insert(stage.name);
  }
  int regimes = 0;
  for (const auto& entry : std::filesystem::directory_iterator("configs/regimes")) {
    if (entry.path().extension() != ".toml") continue;
    ++regimes;
    EXPECT_TRUE(trackers.contains(entry.path().stem().string())) << entry.path();
  }
  EXPECT_GE(regimes, 3);
}

// Every regime's tracker faces the classical bar: its rank lists the regime's CV/CA/CT IMM
// (imm-train baseline with a [classical] config) among its baselines, before the candidates.
TEST(Nightly, EveryTrackerRanksTheClassicalImmAmongItsBaselines) {
  const NightlyPlan plan = load_nightly_plan("configs/nightly.toml");
  for (const auto& stage : plan.stages) {
    if (stage.kind != "tracker") continue;
    SCOPED_TRACE(stage.name);
    const auto& a = stage.arguments;
    const auto baseline = std::find(a.begin(), a.end(), "--baseline");
    const auto candidates = std::find(a.begin(), a.end(), "--candidates");
    ASSERT_LT(baseline, candidates);
    EXPECT_GE(candidates - baseline - 1, 2);
    EXPECT_NE(std::find(baseline, candidates, "models/classical_imm_" + stage.name + ".h5"),
              candidates);
  }
}

// The morning report shows the last `make bench` medians and flags the ones > 10 % slower.
TEST(Nightly, MorningReportShowsBenchmarksAndFlagsSlowdowns) {
  testing::TempDir dir;
  const auto bench = dir.path() / "reports" / "bench";
  std::filesystem::create_directories(bench);
  std::ofstream(bench / "latest.json") << R"({"generated": "2026-11-23T01:00:00Z",
    "previous_run": "2026-11-22T01:00:00Z", "benchmarks": [
    {"name": "BM_W1_PlainImmStep", "median": 560.0, "unit": "ns", "previous": 500.0,
     "change": 0.12, "slower": true},
    {"name": "BM_W3_FuzzyCMeans1d", "median": 0.57, "unit": "ms", "previous": 0.58,
     "change": -0.017, "slower": false}]})";
  const auto night = dir.path() / "reports" / "nightly" / "2026-11-23";
  write_morning_report(night, NightlyPlan{}, NightlyResult{});
  std::ifstream in(night / "index.md");
  const std::string md((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(md.find("| BM_W1_PlainImmStep | 560 ns | 500 ns | +12 % ⚠ |"), std::string::npos) << md;
  EXPECT_NE(md.find("| BM_W3_FuzzyCMeans1d | 0.57 ms | 0.58 ms | -2 % |"), std::string::npos) << md;
}

// An append-only history survives a torn line: a night killed while appending leaves a line
// without its newline, which the next append closes first instead of running into it.
TEST(NightlyHistory, ATornAppendDoesNotSwallowTheNextLine) {
  const testing::TempDir dir;
  const auto file = dir / "nights.jsonl";
  const auto lines_of = [](const std::string& text) {
    std::vector<std::string> lines;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    return lines;
  };
  testing::write_text(file, "{\"night\": \"a\"}\n{\"night\": \"b\", \"sta");
  pipeline::append_line(file, "{\"night\": \"c\"}");
  const auto lines = lines_of(testing::slurp_text(file));
  ASSERT_EQ(lines.size(), 3U);
  EXPECT_EQ(lines[2], "{\"night\": \"c\"}");
  pipeline::append_line(file, "{\"night\": \"d\"}");
  EXPECT_EQ(lines_of(testing::slurp_text(file)).size(), 4U);
}

// The evaluations page describes what is shipped: a section whose model was promoted is
// rewritten from its report; a section whose model was kept stays byte for byte, night after
// night (no date, no blank lines that grow), so a night that ships nothing leaves the checkout
// clean.
TEST(NightlyEvaluationsPage, OnlyPromotionsRewriteTheirSections) {
  testing::TempDir dir;
  const auto page = dir.path() / "evaluations.md";
  NightlyPlan plan;
  NightlyResult result;
  for (const std::string name : {"a", "b"}) {
    NightlyStage model;
    model.kind = "model";
    model.name = name;
    NightlyStage evaluation;
    evaluation.kind = "evaluation";
    evaluation.name = "eval " + name;
    evaluation.model = name;
    evaluation.out = dir.path() / ("report_" + name);
    std::filesystem::create_directories(evaluation.out);
    testing::write_text(evaluation.out / "report.md",
                        "# imm-eval " + name + "\n\n- Written: night 1\n\n| x |\n|---|\n| 1 |\n");
    plan.stages.push_back(model);
    plan.stages.push_back(evaluation);
    StageOutcome promoted;
    promoted.kind = "model";
    promoted.name = name;
    promoted.status = "promoted";
    result.stages.push_back(promoted);
    StageOutcome evaluated;
    evaluated.kind = "evaluation";
    evaluated.name = "eval " + name;
    evaluated.status = "ok";
    result.stages.push_back(evaluated);
  }
  write_evaluations_page(page, plan, result);
  const std::string first = testing::slurp_text(page);
  EXPECT_NE(first.find("- Written: night 1"), std::string::npos) << first;
  // Night 2: both reports say night 2, both models kept; then night 3, model b promoted.
  for (const std::string name : {"a", "b"}) {
    testing::write_text(dir.path() / ("report_" + name) / "report.md",
                        "# imm-eval " + name + "\n\n- Written: night 2\n\n| x |\n|---|\n| 2 |\n");
  }
  for (auto& o : result.stages) {
    if (o.kind == "model") o.status = "kept (ties the shipped model)";
  }
  write_evaluations_page(page, plan, result);
  write_evaluations_page(page, plan, result);
  EXPECT_EQ(testing::slurp_text(page), first);
  result.stages[2].status = "promoted";  // model b
  write_evaluations_page(page, plan, result);
  const std::string third = testing::slurp_text(page);
  const auto b = third.find("## eval b");
  ASSERT_NE(b, std::string::npos) << third;
  EXPECT_NE(third.find("night 2", b), std::string::npos) << third;
  EXPECT_EQ(third.substr(0, b), first.substr(0, first.find("## eval b")));
}

}  // namespace
}  // namespace imm::pipeline
