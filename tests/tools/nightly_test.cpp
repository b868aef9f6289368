// SPDX-License-Identifier: Apache-2.0
// The nightly as a product, driven through `imm-train all` with small plans on a temporary
// registry: promotion, the regression gate (a worse candidate is held back and the shipped model
// stays byte for byte), the stage cache, rollback, a failing stage that does not stop the others,
// and the morning report.

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "testing/hdf5_edit.hpp"
#include "testing/nightly_plans.hpp"
#include "testing/run_tool.hpp"
#include "testing/temp_dir.hpp"
#include "testing/temp_dir.hpp"
#include "testing/tools_fixture.hpp"

// The plans, the tools and run_tool are imm::testing's (testing/nightly_plans.hpp).
namespace imm::testing {
namespace {

TEST(NightlyProduct, PromotesThenHoldsBackAWorseCandidateAndRollsBack) {
  const testing::TempDir dir;
  write_cv3(dir / "cv3.toml", 1.0);
  const Plan p = write_plan(dir);

  // 1. The first candidate enters the manifest.
  auto run = nightly(p);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const fs::path shipped = p.registry / "cv3.h5";
  const std::string first = sha256_of(shipped);
  auto m = manifest(p);
  ASSERT_EQ(m["models"].size(), 1u);
  EXPECT_EQ(m["models"][0]["sha256"], first);
  EXPECT_EQ(m["models"][0]["kind"], "plain_imm");
  EXPECT_EQ(m["models"][0]["regime"]["name"], "");  // a frozen plain IMM is trained for none
  EXPECT_TRUE(m["models"][0]["metrics"].contains("plain-imm cv3: zeta_p"));
  EXPECT_FALSE(fs::exists(p.registry / ".registry" / "staging" / "cv3.h5"));
  // The page of the latest evaluations: the stage, the command that reproduces it, and the
  // tables of its report.md, one heading level down.
  const std::string page = slurp(dir / "docs" / "evaluations.md");
  const std::string evaluation_report = slurp(dir / "reports" / "cv3" / "report.md");
  EXPECT_NE(page.find("# Latest evaluations"), std::string::npos) << page;
  EXPECT_NE(page.find("`imm-eval plain-imm"), std::string::npos) << page;
  const auto table_row = evaluation_report.find("\n|");
  ASSERT_NE(table_row, std::string::npos) << evaluation_report;
  EXPECT_NE(page.find(evaluation_report.substr(
                table_row, evaluation_report.find('\n', table_row + 1) - table_row)),
            std::string::npos)
      << page;
  EXPECT_EQ(page.find("\n# ", 1), std::string::npos) << page;  // one title, the report's below it

  // 2. Nothing changed: every stage is cached, nothing is retrained.
  run = nightly(p);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("cached"), std::string::npos) << run.err;
  EXPECT_EQ(sha256_of(shipped), first);

  // 3. A candidate with 100× the noise levels: passes its own evaluation, but its ζ is worse than
  //    the shipped model's on the same tracks — held back (exit 6), the shipped file untouched.
  write_cv3(dir / "cv3.toml", 100.0);
  run = nightly(p);
  EXPECT_EQ(run.exit_code, 6) << run.err;
  EXPECT_EQ(sha256_of(shipped), first);
  EXPECT_EQ(manifest(p)["models"][0]["sha256"], first);
  const std::string report = slurp(p.reports / "latest" / "index.md");
  EXPECT_NE(report.find("held back"), std::string::npos) << report;
  EXPECT_NE(report.find("zeta_p"), std::string::npos) << report;
  EXPECT_NE(report.find("imm-train freeze"), std::string::npos) << report;  // how to reproduce
  // The first screen: the hold-back first, with what to do; nothing shipped got worse.
  const auto last_night = report.find("## Last night");
  ASSERT_NE(last_night, std::string::npos) << report;
  EXPECT_LT(last_night, report.find("## Stages"));
  EXPECT_NE(report.find("| model cv3 | **held back**", last_night), std::string::npos) << report;
  EXPECT_NE(report.find("`imm-train promote`", last_night), std::string::npos) << report;
  EXPECT_NE(report.find("Did anything shipped get worse? No shipped file changed for the worse"),
            std::string::npos)
      << report;
  // The hold-back's comparison is a table in the HTML, not Markdown pasted into a cell.
  const std::string held_html = slurp(p.reports / "latest" / "index.html");
  const auto held_section = held_html.find("<h2>Failures and hold-backs</h2>");
  ASSERT_NE(held_section, std::string::npos);
  const auto held_table = held_html.find("<table><tr><td>metric</td>", held_section);
  EXPECT_LT(held_table, held_html.find("<h2>Findings</h2>"))
      << held_html.substr(held_section, 3000);
  EXPECT_EQ(nightly(p).exit_code, 6);  // cached, still held back

  // 4. An equally good candidate (another config text) is promoted; rollback restores the first
  //    model byte for byte.
  write_cv3(dir / "cv3.toml", 1.0, "# the same filter\n");
  run = nightly(p);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string second = sha256_of(shipped);
  EXPECT_NE(second, first);
  m = manifest(p);
  EXPECT_EQ(m["models"][0]["sha256"], second);
  ASSERT_EQ(m["models"][0]["history"].size(), 1u);
  EXPECT_EQ(m["models"][0]["history"][0]["sha256"], first);
  // Trends: the model's headline metric at both promotions (an SVG with a point each), and the
  // wall time of every stage that ran over the nights so far (five lines of nights.jsonl).
  const std::string trends = slurp(p.reports / "latest" / "index.html");
  const auto svg = trends.find("<svg", trends.find("id=\"metric-trends\""));
  ASSERT_NE(svg, std::string::npos);
  const std::string plot = trends.substr(svg, trends.find("</svg>", svg) - svg);
  EXPECT_NE(plot.find("cv3: plain-imm cv3: zeta_p"), std::string::npos) << plot;
  std::size_t points = 0;
  for (auto at = plot.find("<circle"); at != std::string::npos; at = plot.find("<circle", at + 1))
    ++points;
  EXPECT_EQ(points, 2u) << plot;
  EXPECT_EQ(testing::lines_of(slurp(p.reports / "nights.jsonl")).size(), 5u);
  EXPECT_NE(slurp(p.reports / "latest" / "index.md").find("| model cv3 |"), std::string::npos);
  // Beside its quality, the model's training cost: its stage's seconds of the last night.
  const std::string trend_md = slurp(p.reports / "latest" / "index.md");
  const auto trend_row = trend_md.find("| cv3 | plain-imm cv3: zeta_p | 2 |");
  ASSERT_NE(trend_row, std::string::npos) << trend_md;
  const std::string row_text =
      trend_md.substr(trend_row, trend_md.find('\n', trend_row) - trend_row);
  EXPECT_EQ(row_text.find("| – |"), std::string::npos) << row_text;

  const auto rollback =
      run_tool("imm-train", {"rollback", "plain_imm", "--registry", p.registry.string()}, {});
  ASSERT_EQ(rollback.exit_code, 0) << rollback.err;
  EXPECT_EQ(sha256_of(shipped), first);
  EXPECT_EQ(manifest(p)["models"][0]["sha256"], first);
  const auto again =
      run_tool("imm-train", {"rollback", "plain_imm", "--registry", p.registry.string()}, {});
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_NE(again.err.find("no earlier model"), std::string::npos) << again.err;

  // 5. The rollback is recorded: the next night retrains the rolled-back model (its inputs are
  //    unchanged) and does not ship it again; the night is green, the report says why.
  m = manifest(p);
  ASSERT_EQ(m["models"][0]["rejected"].size(), 1u) << m.dump(2);
  EXPECT_EQ(m["models"][0]["rejected"][0]["sha256"], second);
  EXPECT_FALSE(m["models"][0]["rejected"][0]["rolled_back_utc"].get<std::string>().empty());
  const auto listed =
      run_tool("imm-inspect", {"--manifest", (p.registry / "manifest.json").string()}, {});
  EXPECT_NE(listed.out.find("- cv3: " + second.substr(0, 12)), std::string::npos) << listed.out;
  run = nightly(p);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(sha256_of(shipped), first);
  EXPECT_NE(slurp(p.reports / "latest" / "index.md").find("rolled back"), std::string::npos);
  // … until a person says so: --force ships it again and ends the record.
  run = nightly(p, {"--force"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string third = sha256_of(shipped);
  EXPECT_NE(third, first);
  m = manifest(p);
  EXPECT_EQ(m["models"][0]["sha256"], third);
  EXPECT_FALSE(m["models"][0].contains("rejected")) << m.dump(2);

  // 6. No news, no churn: retrained from the same config (another training date), the candidate
  //    is the shipped model; the shipped file, the manifest and the evaluations page (which
  //    describes what is shipped: its stamps are the promotion's, not the night's) stay byte for
  //    byte, so a checkout stays clean.
  const std::string manifest_bytes = slurp(p.registry / "manifest.json");
  const std::string page_bytes = slurp(dir / "docs" / "evaluations.md");
  run = nightly(p, {"--force"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(sha256_of(shipped), third);
  EXPECT_EQ(slurp(p.registry / "manifest.json"), manifest_bytes);
  EXPECT_EQ(slurp(dir / "docs" / "evaluations.md"), page_bytes);
  EXPECT_NE(slurp(p.reports / "latest" / "index.md").find("kept (ties the shipped model)"),
            std::string::npos);

  // The manifest prints as a table.
  const auto table =
      run_tool("imm-inspect", {"--manifest", (p.registry / "manifest.json").string()}, {});
  EXPECT_EQ(table.exit_code, 0) << table.err;
  EXPECT_NE(table.out.find("| cv3 | plain_imm |  | cv3.h5 |"), std::string::npos) << table.out;
  // A shipped file edited or gone is named at the end, exit 2 (the listing once showed it as
  // shipped all the same); put back, the listing is clean again.
  const std::string bytes = slurp(shipped);
  testing::write_text(shipped, bytes.substr(0, bytes.size() / 2));
  const auto edited =
      run_tool("imm-inspect", {"--manifest", (p.registry / "manifest.json").string()}, {});
  EXPECT_EQ(edited.exit_code, 2) << edited.err;
  EXPECT_NE(edited.out.find("- cv3: " + shipped.string() + " differs from the manifest's sha256 " +
                            third.substr(0, 12)),
            std::string::npos)
      << edited.out;
  fs::remove(shipped);
  const auto gone =
      run_tool("imm-inspect", {"--manifest", (p.registry / "manifest.json").string()}, {});
  EXPECT_EQ(gone.exit_code, 2) << gone.err;
  EXPECT_NE(gone.out.find("- cv3: " + shipped.string() + " is missing"), std::string::npos)
      << gone.out;
  testing::write_text(shipped, bytes);
  EXPECT_EQ(run_tool("imm-inspect", {"--manifest", (p.registry / "manifest.json").string()}, {})
                .exit_code,
            0);
}

// The regression gate fails closed: when `imm-eval regression` itself fails (a malformed
// headline, runs that differ, a killed tool), the candidate is held back with the reason, never
// promoted "on its own gates". The nightly runs its tools from its own folder: a copy of imm-train
// beside an imm-eval that fails its `regression` subcommand (exit 2, then killed by SIGKILL).
TEST(NightlyProduct, AComparisonThatCannotBeMadeHoldsTheCandidateBack) {
  const testing::TempDir dir;
  const auto [p, night, shipped] = first_night(dir);
  ASSERT_EQ(night.exit_code, 0) << night.err;
  const std::string first = sha256_of(shipped);

  const PlantedTools tools(dir / "bin");
  int round = 0;
  for (const std::string failure : {"exit 2", "kill -9 $$"}) {
    tools.plant("imm-eval",
                "if [ \"$1\" = regression ]; then\n"
                "  echo 'planted: the comparison failed' >&2\n  " +
                    failure + "\nfi\n");
    // The same filter under another config text: a candidate that would tie.
    write_cv3(dir / "cv3.toml", 1.0, "# round " + std::to_string(++round) + "\n");
    const auto run = tools.night(p);
    EXPECT_EQ(run.exit_code, 6) << failure << "\n" << run.err;
    EXPECT_EQ(sha256_of(shipped), first) << failure;
    EXPECT_EQ(manifest(p)["models"][0]["sha256"], first) << failure;
    const std::string report = slurp(p.reports / "latest" / "index.md");
    EXPECT_NE(report.find("held back"), std::string::npos) << report;
    EXPECT_NE(report.find("the comparison with the shipped model failed"), std::string::npos)
        << report;
  }
  // The shipped model's own evaluation killed (it runs on the copy in staging/shipped/): no
  // evidence either, so the candidate is held back and the night is not green.
  tools.plant("imm-eval", "case \"$*\" in *staging/shipped/*) kill -9 $$ ;; esac\n");
  write_cv3(dir / "cv3.toml", 1.0, "# round " + std::to_string(++round) + "\n");
  const auto run = tools.night(p);
  EXPECT_EQ(run.exit_code, 6) << run.err;
  EXPECT_EQ(sha256_of(shipped), first);
  const std::string report = slurp(p.reports / "latest" / "index.md");
  EXPECT_NE(report.find("the evaluation of the shipped model failed"), std::string::npos) << report;
  EXPECT_EQ(report.find("promoted on its own gates"), std::string::npos) << report;
}

// A change a person makes while the night runs stands. The planted imm-eval makes it, as a real
// process, when the night starts it on the shipped model: a rollback, then a promotion by hand of
// another file. The night's candidate, compared with a model that is no longer shipped, is held
// back (and compared with what is shipped on the next night); the person's change is not undone.
TEST(NightlyProduct, AChangeMadeWhileTheNightEvaluatesStands) {
  const testing::TempDir dir;
  const auto [paths, night, shipped] = first_night(dir);
  const Plan& p = paths;  // captured by a lambda below, which a structured binding cannot be
  ASSERT_EQ(night.exit_code, 0) << night.err;
  const std::string a = sha256_of(shipped);
  write_cv3(dir / "cv3.toml", 1.0, "# b\n");
  ASSERT_EQ(nightly(p).exit_code, 0);
  const std::string b = sha256_of(shipped);
  ASSERT_NE(a, b);
  const std::string imm_train = fs::absolute(testing::tool_path("imm-train")).string();
  const PlantedTools tools(dir / "bin");
  const auto during_the_shipped_evaluation = [&](const std::string& command) {
    tools.plant("imm-eval", "case \"$*\" in *staging/shipped/*) " + imm_train + " " + command +
                                " --registry " + p.registry.string() + " >&2 ;; esac\n");
  };

  // 1. A rollback: b → a. The night's candidate c is not shipped over a, and b stays rejected.
  during_the_shipped_evaluation("rollback cv3");
  write_cv3(dir / "cv3.toml", 1.0, "# c\n");
  auto run = tools.night(p);
  EXPECT_EQ(run.exit_code, 6) << run.err;
  EXPECT_EQ(sha256_of(shipped), a);
  auto m = manifest(p);
  EXPECT_EQ(m["models"][0]["sha256"], a);
  ASSERT_EQ(m["models"][0]["rejected"].size(), 1U) << m.dump(2);
  EXPECT_EQ(m["models"][0]["rejected"][0]["sha256"], b);
  std::string report = slurp(p.reports / "latest" / "index.md");
  EXPECT_NE(report.find("the shipped model changed while the candidate was evaluated"),
            std::string::npos)
      << report;

  // 2. A promotion by hand of another file (the same filter, written by a committed build).
  const fs::path by_hand = dir / "by_hand.h5";
  fs::copy_file(shipped, by_hand);
  testing::edit_and_reseal(
      by_hand, [](hid_t f) { testing::set_text_attribute(f, "/", "trainer_version", "f92683f"); });
  const std::string d = sha256_of(by_hand);
  during_the_shipped_evaluation("promote " + by_hand.string() + " --name cv3 --reason better");
  write_cv3(dir / "cv3.toml", 1.0, "# e\n");
  run = tools.night(p);
  EXPECT_EQ(run.exit_code, 6) << run.err;
  EXPECT_EQ(sha256_of(shipped), d);
  m = manifest(p);
  EXPECT_EQ(m["models"][0]["sha256"], d);
  EXPECT_EQ(m["models"][0]["promotion_reason"], "better");
}

// A full disk, as a file-size limit (`ulimit -f`, SIGXFSZ ignored so that writes fail with EFBIG):
// the night says so and changes nothing in the registry — the manifest and the shipped file stay
// byte for byte — and, the failure not being the inputs' fault, it is not cached: the next night
// trains the candidate again and ships it.
TEST(NightlyProduct, AFullDiskChangesNothingAndTheNextNightRecovers) {
  const testing::TempDir dir;
  const auto [p, night, shipped] = first_night(dir);
  ASSERT_EQ(night.exit_code, 0) << night.err;
  const std::string first = sha256_of(shipped);
  const std::string manifest_bytes = slurp(p.registry / "manifest.json");

  write_cv3(dir / "cv3.toml", 1.0, "# news: another config text\n");
  const auto full = run_tool("/bin/sh",
                             {"-c", "trap '' XFSZ; ulimit -f 16; exec \"$0\" \"$@\"",
                              fs::absolute(testing::tool_path("imm-train")).string(), "all",
                              "--config", p.plan.string(), "--reports", p.reports.string()},
                             {}, 300);
  EXPECT_NE(full.exit_code, 0) << full.err;
  EXPECT_LT(full.exit_code, 128) << "crashed: " << full.err;
  EXPECT_NE((full.err + full.out).find("File too large"), std::string::npos) << full.err;
  EXPECT_EQ(sha256_of(shipped), first);
  EXPECT_EQ(slurp(p.registry / "manifest.json"), manifest_bytes);

  const auto next = nightly(p);
  EXPECT_EQ(next.exit_code, 0) << next.err;
  EXPECT_EQ(next.err.find("cached: failed"), std::string::npos) << next.err;
  EXPECT_NE(sha256_of(shipped), first);
  EXPECT_EQ(manifest(p)["models"][0]["sha256"], sha256_of(shipped));
}

// Only outcomes that follow from the inputs are cached: a training killed by a signal (here the
// nightly's imm-train, a script around the real one, kills itself once) is not replayed from the
// stage cache the next night — the stage runs again and its model is promoted.
TEST(NightlyProduct, AKilledStageIsNotReplayedFromTheCache) {
  const testing::TempDir dir;
  write_cv3(dir / "cv3.toml", 1.0);
  const Plan p = write_plan(dir);
  const PlantedTools tools(dir / "bin");
  const fs::path marker = dir / "kill-the-next-training";
  tools.plant("imm-train", "if [ \"$1\" = freeze ] && [ -e " + marker.string() + " ]; then\n  rm " +
                               marker.string() + "\n  kill -9 $$\nfi\n");
  std::ofstream(marker) << "once\n";
  auto run = tools.night(p);
  EXPECT_EQ(run.exit_code, 3) << run.err;
  EXPECT_FALSE(fs::exists(p.registry / "cv3.h5"));
  run = tools.night(p);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(slurp(p.reports / "latest" / "index.md").find("cached: failed"), std::string::npos);
  ASSERT_TRUE(fs::exists(p.registry / "manifest.json"));
  EXPECT_EQ(manifest(p)["models"][0]["name"], "cv3");
}

// Crash consistency, observed: every rename into the registry during a night (the candidate into
// staging, the archive copies, the manifest, the shipped file and its metrics) follows an fsync of
// the file it renames and is followed by an fsync of its folder, so that a power loss leaves the
// old or the new file whole (strace records the system calls of the night and its tools; the
// leak checker, which stops threads with ptrace itself, is off under it).
TEST(NightlyProduct, EveryRenameIntoTheRegistryIsDurable) {
  const testing::TempDir dir;
  write_cv3(dir / "cv3.toml", 1.0);
  const Plan p = write_plan(dir);
  const fs::path trace = dir / "trace.log";
  ASSERT_TRUE(fs::exists("/usr/bin/strace")) << "strace (Debian package, scripts/install-deps.sh)";
  // Where the machine forbids ptrace (a container without it), nothing can be recorded: say so.
  const auto probe = run_tool("/usr/bin/strace", {"-f", "-qq", "-o", "/dev/null", "/bin/true"}, {});
  if (probe.exit_code != 0) GTEST_SKIP() << "strace cannot trace here: " << probe.err;
  const auto run = run_tool("/usr/bin/env",
                            {"ASAN_OPTIONS=detect_leaks=0", "/usr/bin/strace", "-f", "-y", "-qq",
                             "-e", "trace=fsync,fdatasync,rename,renameat,renameat2", "-o",
                             trace.string(), fs::absolute(testing::tool_path("imm-train")).string(),
                             "all", "--config", p.plan.string(), "--reports", p.reports.string()},
                            {}, 600);
  ASSERT_EQ(run.exit_code, 0) << run.err;

  // Per process, in order: fsync(fd<path>) and rename*(…"from", …"to").
  struct Call {
    bool rename = false;
    fs::path path, to;
  };
  std::map<std::string, std::vector<Call>> calls;
  const std::regex fsync_line(R"re(^(\d+)\s+f(?:data)?sync\(\d+<([^>]*)>)re");
  const std::regex rename_line(
      R"re(^(\d+)\s+rename(?:at2?)?\((?:\w+(?:<([^>]*)>)?, )?"([^"]*)", (?:\w+(?:<([^>]*)>)?, )?"([^"]*)")re");
  std::istringstream lines(slurp(trace));
  std::string line;
  std::smatch m;
  while (std::getline(lines, line)) {
    if (std::regex_search(line, m, fsync_line)) {
      calls[m[1]].push_back({false, fs::path(m[2].str()).lexically_normal(), {}});
    } else if (std::regex_search(line, m, rename_line)) {
      const auto absolute = [](const std::string& base, const std::string& path) {
        return (fs::path(path).is_absolute() ? fs::path(path) : fs::path(base) / path)
            .lexically_normal();
      };
      calls[m[1]].push_back({true, absolute(m[2], m[3]), absolute(m[4], m[5])});
    }
  }
  const fs::path registry = fs::absolute(p.registry).lexically_normal();
  int checked = 0;
  for (const auto& [pid, list] : calls) {
    for (std::size_t i = 0; i < list.size(); ++i) {
      const Call& r = list[i];
      if (!r.rename) continue;
      const auto [end, unused] = std::mismatch(registry.begin(), registry.end(), r.to.begin());
      if (end != registry.end()) continue;  // not into the registry
      ++checked;
      const bool file_synced =
          std::any_of(list.begin(), list.begin() + static_cast<long>(i),
                      [&](const Call& c) { return !c.rename && c.path == r.path; });
      const bool folder_synced =
          std::any_of(list.begin() + static_cast<long>(i) + 1, list.end(),
                      [&](const Call& c) { return !c.rename && c.path == r.to.parent_path(); });
      EXPECT_TRUE(file_synced) << r.path << " renamed to " << r.to << " without an fsync of it";
      EXPECT_TRUE(folder_synced) << r.to << ": its folder is not fsynced after the rename";
    }
  }
  // The candidate, its two archive copies (model, metrics), the manifest, the shipped model and
  // its metrics at least.
  EXPECT_GE(checked, 5) << slurp(trace);
}

// A shipped model is never stamped by a build of uncommitted code: with the shipped plan's
// default, such a candidate is not promoted and the morning report says why. Which of the two
// this binary is decides the expectation: a clean build promotes, a dirty one is refused.
TEST(NightlyProduct, ACandidateTrainedFromUncommittedCodeIsNotPromoted) {
  const testing::TempDir dir;
  write_cv3(dir / "cv3.toml", 1.0);
  const Plan p = write_plan(dir, "", /*allow_dirty_trainer=*/false);
  const auto version = run_tool("imm-train", {"--version"}, {});
  ASSERT_EQ(version.exit_code, 0);
  const bool dirty = version.out.find("-dirty)") != std::string::npos;
  const auto run = nightly(p);
  if (dirty) {
    EXPECT_EQ(run.exit_code, 3) << run.err;
    EXPECT_FALSE(fs::exists(p.registry / "cv3.h5"));
    const std::string report = slurp(p.reports / "latest" / "index.md");
    EXPECT_NE(report.find("uncommitted code"), std::string::npos) << report;
  } else {
    EXPECT_EQ(run.exit_code, 0) << run.err;
    EXPECT_TRUE(fs::exists(p.registry / "cv3.h5"));
    EXPECT_EQ(manifest(p)["models"][0]["trainer_version"].get<std::string>().find("-dirty"),
              std::string::npos);
  }
}

}  // namespace
}  // namespace imm::testing
