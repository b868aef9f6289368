// SPDX-License-Identifier: Apache-2.0
// The nightly as a product, driven through `imm-train all` with small plans on a temporary
// registry: promotion, the regression gate (a worse candidate is held back and the shipped model
// stays byte for byte), the stage cache, rollback, a failing stage that does not stop the others,
// and the morning report.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <utility>

#include "testing/hdf5_edit.hpp"
#include "testing/regime_files.hpp"
#include "testing/run_tool.hpp"
#include "testing/shipped_tracker.hpp"
#include "testing/study.hpp"
#include "testing/temp_dir.hpp"
#include "testing/tools_fixture.hpp"

namespace imm {
namespace {

namespace fs = std::filesystem;
using testing::run_tool;
using testing::slurp;

std::string sha256_of(const fs::path& file) {
  const auto result = run_tool("/usr/bin/sha256sum", {file.string()}, {});
  return result.out.substr(0, 64);
}

// The plain IMM of configs/track/cv3_imm.toml with its three noise levels scaled by `scale`.
void write_cv3(const fs::path& path, double scale, const std::string& comment = "") {
  std::string text = slurp("configs/track/cv3_imm.toml");
  for (const char* level : {"1e-6", "1e-4", "1e-2"}) {
    const std::string from = std::string("process_noise = ") + level;
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos);
    text.replace(at, from.size(), "process_noise = " + std::to_string(std::stod(level) * scale));
  }
  std::ofstream(path) << comment << text;
}

struct Plan {
  fs::path dir, registry, plan, reports;
};

// The tests' plans allow a trainer built from uncommitted code (a developer's build tree); the
// refusal is tested on its own below.
Plan write_plan(const testing::TempDir& dir, const std::string& extra_models = "",
                bool allow_dirty_trainer = true) {
  Plan p{dir.path(), dir / "models", dir / "nightly.toml", dir / "nightly"};
  std::ofstream(p.plan) << "registry = \"" << p.registry.string() << "\"\n"
                        << "evaluations_page = \"" << (dir / "docs" / "evaluations.md").string()
                        << "\"\n"
                        << "allow_dirty_trainer = " << (allow_dirty_trainer ? "true" : "false")
                        << "\n[regression]\nrelative_margin = 0.001\n"
                        << "reason = \"rounding across machines\"\n"
                        << extra_models
                        << "[[models]]\nname = \"cv3\"\ncommand = \"freeze\"\nconfig = \""
                        << (dir / "cv3.toml").string() << "\"\n"
                        << "out = \"" << (p.registry / "cv3.h5").string() << "\"\n\n"
                        << "[[evaluations]]\nexperiment = \"plain-imm\"\nmodel = \"cv3\"\nout = \""
                        << (dir / "reports" / "cv3").string()
                        << "\"\nregime = \"configs/regimes/paper/ga_imm_table3.toml\"\nruns = 40\n";
  return p;
}

testing::ToolResult nightly(const Plan& p, std::vector<std::string> extra = {}) {
  std::vector<std::string> arguments = {"all", "--config", p.plan.string(), "--reports",
                                        p.reports.string()};
  arguments.insert(arguments.end(), extra.begin(), extra.end());
  return run_tool("imm-train", arguments, {}, 300);
}

nlohmann::json manifest(const Plan& p) {
  return nlohmann::json::parse(slurp(p.registry / "manifest.json"));
}

// The cv3 plan (write_plan) after its first night, which ships cv3.h5 into its registry.
struct FirstNight {
  Plan plan;
  testing::ToolResult night;  // exit code 0 when the model was shipped
  fs::path shipped;           // the shipped file
};
FirstNight first_night(const testing::TempDir& dir) {
  write_cv3(dir / "cv3.toml", 1.0);
  FirstNight f{write_plan(dir), {}, {}};
  f.night = nightly(f.plan);
  f.shipped = f.plan.registry / "cv3.h5";
  return f;
}

// The nightly's tools with planted faults: the night runs as <bin>/imm-train-night, a copy of
// imm-train (so its tool folder is <bin>), and the tools it starts, <bin>/imm-train and
// <bin>/imm-eval, are scripts that run their `before` lines and then the real tool.
class PlantedTools {
 public:
  explicit PlantedTools(fs::path bin) : bin_(std::move(bin)) {
    fs::create_directories(bin_);
    fs::copy_file(testing::tool_path("imm-train"), bin_ / "imm-train-night");
    plant("imm-train", "");
    plant("imm-eval", "");
  }
  // Rewrites <bin>/<name> to run the shell lines `before` first.
  void plant(const std::string& name, const std::string& before) const {
    std::ofstream(bin_ / name) << "#!/bin/sh\n"
                               << before << "exec "
                               << fs::absolute(testing::tool_path(name)).string() << " \"$@\"\n";
    fs::permissions(bin_ / name, fs::perms::owner_all);
  }
  // Rewrites <bin>/<name> to run the real tool and then the shell lines `after` (the tool's exit
  // code is in $code).
  void plant_after(const std::string& name, const std::string& after) const {
    std::ofstream(bin_ / name) << "#!/bin/sh\n"
                               << fs::absolute(testing::tool_path(name)).string() << " \"$@\"\n"
                               << "code=$?\n"
                               << after << "exit $code\n";
    fs::permissions(bin_ / name, fs::perms::owner_all);
  }
  [[nodiscard]] testing::ToolResult night(const Plan& p) const {
    return run_tool((bin_ / "imm-train-night").string(),
                    {"all", "--config", p.plan.string(), "--reports", p.reports.string()}, {}, 300);
  }

 private:
  fs::path bin_;
};

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

// The cv3 plan and a model stage "broken" whose config is missing (it fails every night).
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

}  // namespace
}  // namespace imm

namespace imm {
namespace {

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
}  // namespace imm
