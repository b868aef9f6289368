// SPDX-License-Identifier: Apache-2.0
// The nightly as a product, continued (nightly_test.cpp has promotion and the regression gate):
// stages that fail alone, a known gate failure, a tie with the baseline, the training sweep, the
// morning report in a headless browser, and kill -9 during promotion.

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <utility>

#include "testing/nightly_plans.hpp"
#include "testing/regime_files.hpp"
#include "testing/run_tool.hpp"
#include "testing/shipped_tracker.hpp"
#include "testing/study.hpp"
#include "testing/temp_dir.hpp"

// The plans, the tools and run_tool are imm::testing's (testing/nightly_plans.hpp).
namespace imm::testing {
namespace {

Plan write_plan_with_a_broken_model(const testing::TempDir& dir) {
  write_cv3(dir / "cv3.toml", 1.0);
  return write_plan(dir, "[[models]]\nname = \"broken\"\ncommand = \"freeze\"\nconfig = \"" +
                             (dir / "missing.toml").string() + "\"\nout = \"" +
                             (dir / "models" / "broken.h5").string() + "\"\n\n");
}

// A stage whose inputs do not read (here its evaluation's tool binary is missing, so the stage has
// no digest) fails alone: the other stages run and the morning report is written.
TEST(NightlyProduct, AStageThatCannotReadItsInputsFailsAlone) {
  const testing::TempDir dir;
  write_cv3(dir / "cv3.toml", 1.0);
  const Plan p = write_plan(dir, "[[models]]\nname = \"solo\"\ncommand = \"freeze\"\nconfig = \"" +
                                     (dir / "cv3.toml").string() + "\"\nout = \"" +
                                     (dir / "models" / "solo.h5").string() + "\"\n\n");
  const PlantedTools tools(dir / "bin");
  fs::remove(dir / "bin" / "imm-eval");
  const auto run = tools.night(p);
  EXPECT_EQ(run.exit_code, 3) << run.err;
  EXPECT_TRUE(fs::exists(p.registry / "solo.h5"));
  EXPECT_FALSE(fs::exists(p.registry / "cv3.h5"));
  const std::string report = slurp(p.reports / "latest" / "index.md");
  EXPECT_NE(report.find("model cv3 — failed"), std::string::npos) << report;
  EXPECT_NE(report.find("imm-eval: cannot open"), std::string::npos) << report;
}

TEST(NightlyProduct, AFailingStageDoesNotStopTheOthers) {
  const testing::TempDir dir;
  const Plan p = write_plan_with_a_broken_model(dir);
  const auto run = nightly(p);
  EXPECT_EQ(run.exit_code, 3) << run.err;
  EXPECT_TRUE(fs::exists(p.registry / "cv3.h5"));  // the stage after the failure ran
  EXPECT_FALSE(fs::exists(p.registry / "broken.h5"));
  const std::string report = slurp(p.reports / "latest" / "index.md");
  EXPECT_NE(report.find("model broken — failed"), std::string::npos) << report;
  EXPECT_NE(report.find("missing.toml"), std::string::npos) << report;
  const std::string html = slurp(p.reports / "latest" / "index.html");
  EXPECT_NE(html.find("<table id=\"stages\">"), std::string::npos);
  EXPECT_EQ(html.find("src=\"reports"), std::string::npos);  // nothing linked: self-contained
  bool plots = false;
  for (const auto& f : fs::directory_iterator(dir / "reports" / "cv3")) {
    plots |= f.path().extension() == ".png";
  }
  if (plots) {
    EXPECT_NE(html.find("data:image/png;base64,"), std::string::npos);
  }
}

// A gate the plan knows fails ([[evaluations.known_failures]], with its reason) is a finding, not
// a failure: the candidate is promoted past it and the night is green. Any other failed gate still
// fails the stage; a known failure that stops happening is reported as news.
TEST(NightlyProduct, AKnownGateFailureIsAFindingAndAnyOtherFailsTheNight) {
  const testing::TempDir dir;
  write_cv3(dir / "cv3.toml", 1.0);
  const Plan p = write_plan(dir);
  std::ofstream(p.plan, std::ios::app)
      << "[[evaluations.known_failures]]\ngate = \"pos_rmse_maneuver is above KF's\"\n"
      << "reason = \"the onset of the first zigzag, measured\"\n";
  const PlantedTools tools(dir / "bin");
  // The evaluation's gates fail in one line (the real report, then a planted gate block).
  const auto fail_with = [&](const std::string& line) {
    tools.plant_after("imm-eval",
                      "if [ $code -eq 0 ] && [ \"$1\" = plain-imm ]; then\n"
                      "  echo 'Gates (planted): FAILED'\n  echo \"  - " +
                          line + "\"\n  exit 5\nfi\n");
  };
  fail_with("FCM-IMM's pos_rmse_maneuver is above KF's beyond the uncertainty (+1.09)");
  auto run = tools.night(p);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(fs::exists(p.registry / "cv3.h5"));
  std::string report = slurp(p.reports / "latest" / "index.md");
  EXPECT_NE(report.find("plain-imm cv3 — known failure"), std::string::npos) << report;
  EXPECT_NE(report.find("the onset of the first zigzag, measured"), std::string::npos) << report;
  const std::string shipped = sha256_of(p.registry / "cv3.h5");

  // Another gate fails beside it: the stage fails, the shipped file stays.
  write_cv3(dir / "cv3.toml", 1.5);
  fail_with("FCM-IMM's pos_rmse is above KF's beyond the uncertainty (+3.1)");
  run = tools.night(p);
  EXPECT_EQ(run.exit_code, 3) << run.err;
  EXPECT_EQ(sha256_of(p.registry / "cv3.h5"), shipped);
  report = slurp(p.reports / "latest" / "index.md");
  EXPECT_NE(report.find("plain-imm cv3 — gate failed"), std::string::npos) << report;

  // Every gate passes: green, and the known failure that did not happen is news.
  write_cv3(dir / "cv3.toml", 1.0);
  tools.plant_after("imm-eval", "");
  run = tools.night(p);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  report = slurp(p.reports / "latest" / "index.md");
  EXPECT_NE(report.find("'pos_rmse_maneuver is above KF's' no longer happens"), std::string::npos)
      << report;
}

// A night whose only news is that a model ties the regime's tuned baseline: the tracker stage
// ranks both shipped files, ships the baseline as the regime's tracker (the other does not beat
// it beyond the interval — here it is the same filter under another config text, so it ties to
// the bit), reports that as a finding, and the night exits 0.
TEST(NightlyProduct, ANightWhoseOnlyNewsIsATieWithTheBaselineIsGreenAndShipsTheBaseline) {
  const testing::TempDir dir;
  const auto regime =
      testing::write_preset_variant(dir, "ga_imm_training",
                                    {{"name = \"ga_imm_training\"", "name = \"small\""},
                                     {"scans = 160", "scans = 60"},
                                     {"training = 9", "training = 2"},
                                     {"validation = 6", "validation = 1"},
                                     {"test = 100", "test = 10"}});
  const std::string tuned = slurp("configs/ga_fuzzy_imm_tuned.toml");
  std::ofstream(dir / "tuned.toml") << tuned;
  std::ofstream(dir / "again.toml") << "# the same filter under another config text\n" << tuned;
  const fs::path registry = dir / "models";
  const auto model = [&](const std::string& name, const std::string& config) {
    return "[[models]]\nname = \"" + name + "\"\ncommand = \"baseline\"\nconfig = \"" +
           (dir / config).string() + "\"\nregime = \"" + regime.string() + "\"\nout = \"" +
           (registry / (name + ".h5")).string() + "\"\n\n";
  };
  const Plan p{dir.path(), registry, dir / "nightly.toml", dir / "nightly"};
  std::ofstream(p.plan) << "registry = \"" << registry.string() << "\"\n"
                        << "allow_dirty_trainer = true\n"
                        << model("base", "tuned.toml") << model("again", "again.toml")
                        << "[[trackers]]\nname = \"small\"\nbaseline = \"base\"\n"
                        << "candidates = [\"again\"]\nout = \""
                        << (registry / "small" / "tracker.h5").string() << "\"\nreport = \""
                        << (dir / "reports" / "small").string() << "\"\n";
  const auto run = nightly(p);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  testing::expect_winner_with_calibration(registry / "small" / "tracker.h5", registry / "base.h5");
  const auto m = manifest(p);
  nlohmann::json tracker;
  for (const auto& entry : m["models"]) {
    if (entry["name"] == "small") tracker = entry;
  }
  ASSERT_FALSE(tracker.is_null()) << m.dump(2);
  EXPECT_EQ(tracker["file"], "small/tracker.h5");
  EXPECT_EQ(tracker["metrics"]["tracker"], "base");
  ASSERT_EQ(tracker["metrics"]["ranking"].size(), 2u);
  EXPECT_EQ(tracker["metrics"]["ranking"][1]["verdict"], "ties");
  const std::string report = slurp(p.reports / "latest" / "index.md");
  EXPECT_NE(report.find("## The regime's trackers"), std::string::npos) << report;
  // The plan evaluates no candidate, so "again" is also held out as unchecked by its own gates.
  EXPECT_NE(report.find("no eligible learned model beats the classical bar"), std::string::npos)
      << report;
  EXPECT_NE(report.find("again is held out of the choice"), std::string::npos) << report;
  EXPECT_NE(report.find("1 with findings"), std::string::npos) << report;
  EXPECT_NE(report.find("again ties the classical bar"), std::string::npos) << report;
  // Three entries share the kind and the regime (the baseline, the other model, the tracker): a
  // rollback by kind and regime is ambiguous and says how to name one; by name it finds the one.
  const auto ambiguous = run_tool(
      "imm-train", {"rollback", "ga_fuzzy_imm", "small", "--registry", registry.string()}, {});
  EXPECT_EQ(ambiguous.exit_code, 2);
  EXPECT_NE(ambiguous.err.find("name one"), std::string::npos) << ambiguous.err;
  const auto by_name =
      run_tool("imm-train", {"rollback", "small", "--registry", registry.string()}, {});
  EXPECT_EQ(by_name.exit_code, 2);  // the first tracker has no earlier one to restore
  EXPECT_NE(by_name.err.find("'small' has no earlier model"), std::string::npos) << by_name.err;
  // Unchanged inputs: the tracker stage is cached like any other.
  const auto again = nightly(p);
  EXPECT_EQ(again.exit_code, 0) << again.err;
  EXPECT_NE(again.err.find("cached"), std::string::npos) << again.err;
}

// `imm-train all --sweep` trains every stale candidate first in one `imm-train sweep`, then
// evaluates and promotes each as its own stage would; a sweep that reports nothing (its launcher
// failed) leaves the trainings to their stages. Under mpirun: tests/tools/mpi_test.cpp.
TEST(NightlyProduct, CandidatesTrainInOneSweepAndAFailedSweepLeavesThemToTheirStages) {
  const testing::TempDir dir;
  const Plan p = write_plan_with_a_broken_model(dir);
  auto run = nightly(p, {"--sweep"});
  EXPECT_EQ(run.exit_code, 3) << run.err;
  ASSERT_TRUE(fs::exists(p.registry / "cv3.h5")) << run.err;
  EXPECT_FALSE(fs::exists(p.registry / "broken.h5"));
  std::string report = slurp(p.reports / "latest" / "index.md");
  EXPECT_NE(report.find("Training: 2 candidates trained in one sweep over 1 rank in "),
            std::string::npos)
      << report;
  EXPECT_NE(report.find("imm-train sweep --config"), std::string::npos) << report;
  EXPECT_NE(report.find("model broken — failed"), std::string::npos) << report;
  EXPECT_NE(report.find("missing.toml"), std::string::npos) << report;  // why, from its log
  EXPECT_NE(report.find("| cv3 | promoted (first in the manifest) |"), std::string::npos) << report;
  // Each training's output is in its stage's log, as when it runs as its own process.
  const fs::path logs = p.reports / "latest" / "logs";
  EXPECT_NE(slurp(logs / "model_cv3.err").find("froze"), std::string::npos);
  EXPECT_NE(slurp(logs / "model_broken.err").find("missing.toml"), std::string::npos);
  EXPECT_EQ(slurp(logs / "sweep.err").find("froze"), std::string::npos);
  EXPECT_NE(slurp(logs / "sweep.err").find("broken FAILED"), std::string::npos);
  const nlohmann::json manifest_after_sweep = manifest(p);

  // Nothing changed: everything is cached, no sweep starts.
  run = nightly(p, {"--sweep"});
  EXPECT_EQ(run.exit_code, 3) << run.err;
  EXPECT_EQ(run.err.find("sweep"), std::string::npos) << run.err;

  // A launcher that fails: the sweep reports nothing and the candidate trains as its own stage
  // (the broken stage's inputs did not change: it stays cached).
  write_cv3(dir / "cv3.toml", 1.0, "# the same filter\n");
  run = nightly(p, {"--launcher", "/bin/false"});
  EXPECT_EQ(run.exit_code, 3) << run.err;
  report = slurp(p.reports / "latest" / "index.md");
  EXPECT_NE(report.find("Training: the sweep of 1 candidate ("), std::string::npos) << report;
  EXPECT_NE(report.find("ended with exit code 1"), std::string::npos) << report;
  EXPECT_NE(report.find("the candidates it did not report on (1) were trained as their own stages"),
            std::string::npos)
      << report;
  EXPECT_NE(report.find("| cv3 | promoted |"), std::string::npos) << report;
  EXPECT_NE(report.find("missing.toml"), std::string::npos) << report;
  EXPECT_NE(manifest(p)["models"][0]["sha256"], manifest_after_sweep["models"][0]["sha256"]);

  // The sweep hands out the longest training first, by how long each took the last time it ran.
  const fs::path cache_file = p.registry / ".registry" / "nightly-cache.json";
  for (const auto& [longest, shortest] :
       std::vector<std::pair<std::string, std::string>>{{"broken", "cv3"}, {"cv3", "broken"}}) {
    SCOPED_TRACE(longest);
    auto cache = nlohmann::json::parse(slurp(cache_file));
    cache["stages"]["model:" + longest]["wall_seconds"] = 100.0;
    cache["stages"]["model:" + shortest]["wall_seconds"] = 1.0;
    testing::write_text(cache_file, cache.dump());
    run = nightly(p, {"--sweep", "--force"});
    EXPECT_EQ(run.exit_code, 3) << run.err;
    const std::string jobs = slurp(p.registry / ".registry" / "staging" / "sweep.toml");
    ASSERT_NE(jobs.find("name = '" + shortest + "'"), std::string::npos) << jobs;
    EXPECT_LT(jobs.find("name = '" + longest + "'"), jobs.find("name = '" + shortest + "'"))
        << jobs;
  }
}

// A sweep's jobs given as imm-train command lines (the nightly's form), each with its own log,
// and the plans a sweep refuses before anything trains.
TEST(SweepPlan, CommandJobsRunTheirSubcommandIntoTheirLogsAndBadPlansAreRefused) {
  const testing::TempDir dir;
  const fs::path plan = dir / "sweep.toml";
  std::ofstream(plan) << "[[jobs]]\nname = \"cv3\"\ncommand = [\"freeze\", \"--config\", "
                         "\"configs/track/cv3_imm.toml\", \"--out\", \""
                      << (dir / "out" / "cv3.h5").string() << "\"]\nlog = \""
                      << (dir / "logs" / "cv3").string()
                      << "\"\n\n[[jobs]]\ncommand = [\"import-rules\", \"--csv\", "
                         "\"configs/reference/ga_fuzzy_imm_paper_rules.csv\", \"--config\", "
                         "\"configs/ga_fuzzy_imm.toml\", \"--out\", \""
                      << (dir / "out" / "paper.h5").string() << "\"]\n";
  const fs::path summary = dir / "summary.json";
  const auto swept = run_tool(
      "imm-train", {"sweep", "--config", plan.string(), "--summary", summary.string()}, {}, 120);
  ASSERT_EQ(swept.exit_code, 0) << swept.err;
  EXPECT_TRUE(fs::exists(dir / "out" / "cv3.h5"));
  EXPECT_TRUE(fs::exists(dir / "out" / "paper.h5"));
  // The logged job's output is in its log only; the other's goes to the sweep's stderr.
  EXPECT_NE(slurp(dir / "logs" / "cv3.err").find("froze"), std::string::npos);
  EXPECT_EQ(swept.err.find("froze"), std::string::npos) << swept.err;
  EXPECT_NE(swept.err.find("imported 3 levels"), std::string::npos) << swept.err;
  const auto outcomes = nlohmann::json::parse(slurp(summary));
  EXPECT_EQ(outcomes["ranks"], 1);
  ASSERT_EQ(outcomes["jobs"].size(), 2U);
  EXPECT_EQ(outcomes["jobs"][0]["name"], "cv3");
  EXPECT_EQ(outcomes["jobs"][0]["exit_code"], 0);
  EXPECT_EQ(outcomes["jobs"][1]["name"], "import-rules " + (dir / "out" / "paper.h5").string());
  EXPECT_EQ(outcomes["jobs"][1]["exit_code"], 0);

  // Refused, naming the key, before anything trains.
  const std::string out = (dir / "refused.h5").string();
  for (const auto& [jobs, expected] : std::vector<std::pair<std::string, std::string>>{
           {"command = [\"all\", \"--config\", \"configs/nightly.toml\", \"--out\", \"" + out +
                "\"]",
            "'jobs[0].command': 'all' is not a subcommand that writes a model file"},
           {"command = [\"freeze\", \"--config\", \"configs/track/cv3_imm.toml\"]",
            "'jobs[0].command': gives no --out FILE"},
           {"command = []", "'jobs[0].command': an empty command"},
           {"command = [\"freeze\", \"--config\", \"configs/track/cv3_imm.toml\", \"--bogus\", "
            "\"--out\", \"" +
                out + "\"]",
            "'jobs': 'freeze " + out +
                "' is not an imm-train command line: The following "
                "argument was not expected: --bogus"},
           {"kind = \"ga\"\ncommand = [\"ga\", \"--out\", \"" + out + "\"]",
            "'jobs[0].command': a job is either"},
           {"kind = \"mlp\"\nconfig = \"configs/mlp_input_estimator.toml\"\nout = \"" + out +
                "\"\nlog = \"logs/{seed}\"",
            "'jobs[0].log': names {seed}, but the job lists no seeds"}}) {
    SCOPED_TRACE(jobs);
    std::ofstream(plan) << "[[jobs]]\n" << jobs << "\n";
    const auto refused = run_tool("imm-train", {"sweep", "--config", plan.string()}, {}, 60);
    EXPECT_EQ(refused.exit_code, 2);
    EXPECT_NE(refused.err.find(expected), std::string::npos) << refused.err;
    EXPECT_FALSE(fs::exists(out));
  }
}

// What a reader of the morning report sees, rendered by a real browser (Debian's chromium,
// headless): the stage table and the evaluation's tables laid out with a size, every embedded plot
// decoded to an image with pixels, and not one request leaving the page (a Content-Security-Policy
// that allows only inline data records every attempt, and the page's resource timing lists every
// fetch). In CI (CI=true) a missing browser is a failure; elsewhere the test skips and says why.
TEST(NightlyProduct, TheReportRendersInAHeadlessBrowser) {
  std::string browser;
  for (const char* candidate : {"/usr/bin/chromium", "/usr/bin/chromium-browser"}) {
    if (fs::exists(candidate)) browser = candidate;
  }
  if (browser.empty()) {
    const char* ci = std::getenv("CI");
    if (ci != nullptr && std::string(ci) == "true") {
      FAIL() << "CI=true and no headless browser: scripts/install-deps.sh installs chromium";
    }
    GTEST_SKIP() << "no headless browser (Debian's chromium, scripts/install-deps.sh) here";
  }
  const testing::TempDir dir;
  const auto [p, night, shipped] = first_night(dir);
  ASSERT_EQ(night.exit_code, 0) << night.err;

  // The report as shipped, with a probe in front of it: the policy and the probe script come
  // before any of the report's own content, so they see every request it makes.
  std::string page = slurp(p.reports / "latest" / "index.html");
  // After the charset declaration, which must stay within the page's first 1024 bytes.
  const std::string charset = "<meta charset=\"utf-8\">";
  const auto head = page.find(charset);
  ASSERT_NE(head, std::string::npos) << "index.html declares no charset";
  const std::string probe = R"(
<meta http-equiv="Content-Security-Policy"
      content="default-src 'none'; img-src data:; style-src 'unsafe-inline'; script-src 'unsafe-inline'">
<script>
const blocked = [];
document.addEventListener('securitypolicyviolation', e => blocked.push(e.blockedURI));
window.addEventListener('load', () => {
  const images = [...document.images];
  const seen = {
    images: images.length,
    decoded: images.filter(i => i.complete && i.naturalWidth > 0 && i.naturalHeight > 0).length,
    tables: [...document.querySelectorAll('table')].map(t => ({
      id: t.id, rows: t.rows.length, height: t.getBoundingClientRect().height})),
    news: document.getElementById('news') ? document.getElementById('news').getBoundingClientRect().top : -1,
    stages_top: document.getElementById('stages').getBoundingClientRect().top,
    trends: document.querySelectorAll('#metric-trends svg circle').length,
    blocked: blocked,
    fetched: performance.getEntriesByType('resource').map(r => r.name)
                 .filter(n => !n.startsWith('data:')),
    text: document.body.innerText
  };
  const out = document.createElement('pre');
  out.id = 'render-probe';
  out.textContent = JSON.stringify(seen);
  document.body.appendChild(out);
});
</script>
)";
  page.insert(head + charset.size(), probe);
  const fs::path probed = dir / "probed.html";
  std::ofstream(probed) << page;

  const auto dom =
      run_tool(browser,
               {"--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                "--user-data-dir=" + (dir / "browser-profile").string(), "--window-size=1400,900",
                "--virtual-time-budget=10000", "--dump-dom", "file://" + probed.string()},
               {}, 120);
  ASSERT_EQ(dom.exit_code, 0) << dom.err;
  const std::string open = "<pre id=\"render-probe\">";
  const auto begin = dom.out.find(open);
  const auto end = dom.out.find("</pre>", begin);
  ASSERT_TRUE(begin != std::string::npos && end != std::string::npos) << "the probe did not run:\n"
                                                                      << dom.out.substr(0, 2000);
  // --dump-dom serializes the text node: undo the HTML escaping of the JSON.
  std::string json = dom.out.substr(begin + open.size(), end - begin - open.size());
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"&quot;", "\""}, {"&lt;", "<"}, {"&gt;", ">"}, {"&amp;", "&"}}) {
    for (auto at = json.find(from); at != std::string::npos; at = json.find(from, at)) {
      json.replace(at, from.size(), to);
      at += to.size();
    }
  }
  const auto seen = nlohmann::json::parse(json);

  // Every embedded plot decodes to an image with pixels (the evaluation writes at least one).
  EXPECT_GE(seen["images"].get<int>(), 1);
  EXPECT_EQ(seen["decoded"], seen["images"]);
  // Nothing left the page.
  EXPECT_TRUE(seen["blocked"].empty()) << seen["blocked"].dump();
  EXPECT_TRUE(seen["fetched"].empty()) << seen["fetched"].dump();
  // The stage table is laid out with a row per stage, and every table has a visible height.
  bool stages = false;
  for (const auto& table : seen["tables"]) {
    EXPECT_GT(table["height"].get<double>(), 0.0) << table.dump();
    if (table["id"] == "stages") {
      stages = true;
      EXPECT_GE(table["rows"].get<int>(), 3) << "a header, the model and the evaluation";
    }
  }
  EXPECT_TRUE(stages) << "no stage table rendered";
  // The first screen (1400 × 900) answers what changed: the news table starts on it, above the
  // stage table; the metric's trend is drawn (one promotion, one point).
  EXPECT_GE(seen["news"].get<double>(), 0.0) << seen.dump();
  EXPECT_LT(seen["news"].get<double>(), 900.0) << seen.dump();
  EXPECT_LT(seen["news"].get<double>(), seen["stages_top"].get<double>());
  EXPECT_EQ(seen["trends"], 1);
  // What a reader reads: the decision and the evaluation's table.
  const std::string text = seen["text"];
  EXPECT_NE(text.find("promoted"), std::string::npos) << text.substr(0, 2000);
  EXPECT_NE(text.find("cv3"), std::string::npos);
}

// kill -9 at random points of nightlies that promote: the manifest is always whole (the old or the
// new), and the next nightly leaves the shipped file equal to the manifest's SHA-256 with no
// temporary file behind.
TEST(NightlyProduct, KillNineDuringPromotionLeavesTheOldOrTheNewState) {
  const testing::TempDir dir;
  const auto [p, night, shipped] = first_night(dir);
  ASSERT_EQ(night.exit_code, 0) << night.err;
  std::uint64_t state = 12345;
  const int rounds = testing::quick_or_study(8, 20);  // make test-long: 20
  for (int round = 0; round < rounds; ++round) {
    // Each round a new config text, so that every run trains, evaluates and promotes.
    write_cv3(dir / "cv3.toml", 1.0, "# round " + std::to_string(round) + "\n");
    const std::string out = (dir / "out.txt").string(), err = (dir / "err.txt").string();
    const pid_t pid = testing::start_tool(
        "imm-train", {"all", "--config", p.plan.string(), "--reports", p.reports.string()}, out,
        err);
    ASSERT_GT(pid, 0);
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    const auto delay_us = static_cast<useconds_t>((state >> 33) % 1500000);  // 0 … 1.5 s
    ::usleep(delay_us);
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    if (fs::exists(p.registry / "manifest.json")) {
      EXPECT_NO_THROW((void)manifest(p)) << "round " << round;
    }
    const auto rerun = nightly(p);
    ASSERT_TRUE(rerun.exit_code == 0) << "round " << round << ": " << rerun.err;
    const auto m = manifest(p);
    EXPECT_EQ(m["models"][0]["sha256"], sha256_of(shipped)) << "round " << round;
    for (const auto& f : fs::recursive_directory_iterator(p.registry)) {
      EXPECT_EQ(f.path().filename().string().find(".tmp-"), std::string::npos)
          << f.path() << " left behind in round " << round;
    }
    EXPECT_FALSE(fs::exists(p.registry / ".registry" / "staging" / "cv3.h5"));
  }
}

}  // namespace
}  // namespace imm::testing
