// SPDX-License-Identifier: Apache-2.0
// The trainer and the evaluator under mpirun (Debian's OpenMPI): a GA model, a sweep's models and
// every evaluation figure the same to the bit at 1, 2 and 3 ranks (3 oversubscribed on a 2-core
// machine) as without MPI; a sweep's broken job does not stop the others; a rank killed mid-run
// ends the job with an error and leaves no model behind.
//
// The developers' machines and CI run as root, which OpenMPI refuses unless told otherwise: the
// tests set OMPI_ALLOW_RUN_AS_ROOT(_CONFIRM); a user's cluster needs neither.

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "imm/io/container_file.hpp"
#include "testing/regime_files.hpp"
#include "testing/run_tool.hpp"
#include "testing/study.hpp"
#include "testing/temp_dir.hpp"

namespace imm {
namespace {

namespace fs = std::filesystem;

#ifdef IMM_MPIEXEC
constexpr const char* kMpiexec = IMM_MPIEXEC;
#else
constexpr const char* kMpiexec = "";
#endif

class Mpi : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::string(kMpiexec).empty()) GTEST_SKIP() << "built without MPI (IMM_WITH_MPI=OFF)";
    ::setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
    ::setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
    // Containers forbid the cross-memory attach OpenMPI's shared-memory transport tries first.
    ::setenv("OMPI_MCA_btl_vader_single_copy_mechanism", "none", 1);
  }

  /// `tool arguments…` as one process (ranks = 0) or under `mpirun -np ranks`.
  static testing::ToolResult run(int ranks, const std::string& tool,
                                 const std::vector<std::string>& arguments,
                                 double timeout_seconds = 600.0) {
    if (ranks == 0) return testing::run_tool(tool, arguments, fs::current_path(), timeout_seconds);
    std::vector<std::string> launch{"-np", std::to_string(ranks), "--oversubscribe",
                                    testing::tool_path(tool).string()};
    launch.insert(launch.end(), arguments.begin(), arguments.end());
    return testing::run_tool(kMpiexec, launch, fs::current_path(), timeout_seconds);
  }
};

/// A small GA (the kill drill's size): 3 levels, population 24, 8 generations.
struct SmallGa {
  fs::path config, regime;
  explicit SmallGa(const testing::TempDir& dir, int generations = 8) {
    regime = testing::write_preset_variant(dir, "ga_imm_training",
                                           {{"scans = 160", "scans = 60"},
                                            {"training = 9 ", "training = 2 "},
                                            {"validation = 6", "validation = 1"}});
    std::string text = testing::slurp("configs/ga_fuzzy_imm.toml");
    for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
             {"population = 500", "population = 24"},
             {"generations = 100", "generations = " + std::to_string(generations)}}) {
      const auto at = text.find(from);
      if (at == std::string::npos) throw std::runtime_error("ga_fuzzy_imm.toml: no '" + from + "'");
      text.replace(at, from.size(), to);
    }
    config = dir / "ga.toml";
    testing::write_text(config, text);
  }
  [[nodiscard]] std::vector<std::string> arguments(const fs::path& out) const {
    return {"ga",    "--config",   config.string(), "--regime", regime.string(),
            "--out", out.string(), "--threads",     "1"};
  }
};

/// Every dataset and attribute of a model file, but the moments it records: when it was written
/// and how long each level took.
std::map<std::string, std::string> model_contents(const fs::path& path) {
  const io::ContainerReader reader(path, "immtrain-model");
  std::map<std::string, std::string> contents;
  for (const std::string& object : reader.objects()) {
    if (reader.kind(object) == io::ObjectKind::kDataset) {
      std::string bytes;
      for (double value : reader.read(object).values) {
        bytes.append(reinterpret_cast<const char*>(&value), sizeof value);
      }
      contents[object] = bytes;
    }
    for (const std::string& name : reader.attribute_names(object)) {
      if (name == "created_utc" || name == "wall_seconds") continue;
      const auto value = reader.attribute(object, name);
      std::string text;
      if (const auto* s = std::get_if<std::string>(&*value)) text = *s;
      if (const auto* i = std::get_if<std::int64_t>(&*value)) text = std::to_string(*i);
      if (const auto* d = std::get_if<double>(&*value)) {
        text.assign(reinterpret_cast<const char*>(d), sizeof *d);
      }
      contents[object + "@" + name] = text;
    }
  }
  return contents;
}

TEST_F(Mpi, GaModelIsTheSameAtOneTwoAndThreeRanksAsWithoutMpi) {
  const testing::TempDir dir;
  const SmallGa ga(dir);
  const auto alone = run(0, "imm-train", ga.arguments(dir / "alone.h5"));
  ASSERT_EQ(alone.exit_code, 0) << alone.err;
  const auto expected = model_contents(dir / "alone.h5");
  ASSERT_GT(expected.size(), 20U);
  for (int ranks : {1, 2, 3}) {
    SCOPED_TRACE(std::to_string(ranks) + " ranks");
    const fs::path out = dir / ("ranks" + std::to_string(ranks) + ".h5");
    const auto result = run(ranks, "imm-train", ga.arguments(out));
    ASSERT_EQ(result.exit_code, 0) << result.err;
    EXPECT_EQ(model_contents(out), expected);
    // The root alone writes: one model, its metrics, no checkpoint left, no temporaries.
    std::vector<std::string> files;
    for (const auto& entry : fs::directory_iterator(dir.path())) {
      const std::string name = entry.path().filename().string();
      if (name.find("ranks" + std::to_string(ranks)) != std::string::npos) files.push_back(name);
    }
    std::sort(files.begin(), files.end());
    EXPECT_EQ(files, (std::vector<std::string>{"ranks" + std::to_string(ranks) + ".h5",
                                               "ranks" + std::to_string(ranks) + ".metrics.json"}));
  }
}

TEST_F(Mpi, GaResumesUnderMpiFromACheckpointToTheSameModel) {
  const testing::TempDir dir;
  const SmallGa ga(dir);
  const auto alone = run(0, "imm-train", ga.arguments(dir / "alone.h5"));
  ASSERT_EQ(alone.exit_code, 0) << alone.err;
  // A checkpoint from a single-process run stopped half way (the kill drill's way: the process
  // is killed), resumed by two ranks.
  const fs::path out = dir / "resumed.h5";
  const pid_t pid = testing::spawn_tool("imm-train", ga.arguments(out));
  ASSERT_GT(pid, 0);
  const fs::path checkpoint = dir / "resumed.h5.checkpoint";
  for (int wait = 0; wait < 3000 && !fs::exists(checkpoint); ++wait) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ::kill(pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  std::vector<std::string> resume = ga.arguments(out);
  resume.emplace_back("--resume");
  const auto resumed = run(2, "imm-train", resume);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  EXPECT_NE(resumed.err.find("resuming level"), std::string::npos) << resumed.err;
  EXPECT_EQ(model_contents(out), model_contents(dir / "alone.h5"));
  EXPECT_FALSE(fs::exists(checkpoint));
}

TEST_F(Mpi, EvaluationFiguresAreTheSameAtAnyRankCount) {
  const testing::TempDir dir;
  // Every experiment: plain-imm and ga-imm through run_monte_carlo (ga-imm with a recorder of
  // q_j over scans), the other four through their own loops over shared_items (wimm's also in
  // its baseline's tuning). Few runs: a gate may fail (exit 5), the same way at every count.
  // The classical bar each lists is given as the file imm-train baseline writes (its search runs
  // the same on every rank, and would run once per rank count otherwise).
  const auto classical = [&](const std::string& regime) {
    const fs::path file = dir / ("classical_" + regime + ".h5");
    const auto tuned =
        testing::run_tool("imm-train",
                          {"baseline", "--config", "configs/classical_imm.toml", "--regime",
                           "configs/regimes/paper/" + regime + ".toml", "--out", file.string()},
                          fs::current_path());
    EXPECT_EQ(tuned.exit_code, 0) << tuned.err;
    return file.string();
  };
  std::vector<std::vector<std::string>> experiments{
      {"plain-imm", "--runs", "41"},
      {"ga-imm", "--runs", "13", "--classical", classical("ga_imm_training")},
      {"fimm", "--runs", "8"},
      {"fcm-imm", "--runs", "9", "--classical", classical("fcm_imm_training")},
      {"input-estimator", "--runs", "5", "--classical", classical("input_estimator_training")}};
  // The wIMM (its polar regime's classical bar alone takes 7 s to tune) under make test-long.
  if (testing::running_as_study()) {
    experiments.push_back({"wimm", "--runs", "6", "--classical", classical("wimm_training")});
  }
  for (const std::vector<std::string>& experiment : experiments) {
    SCOPED_TRACE(experiment.front());
    std::map<int, std::string> metrics, headline;
    std::map<int, int> exit_codes;
    for (int ranks : {0, 3}) {  // 3 ranks: runs that do not divide evenly
      const fs::path out = dir / (experiment.front() + std::to_string(ranks));
      std::vector<std::string> arguments = experiment;
      arguments.insert(arguments.end(), {"--seed", "7", "--out", out.string()});
      const auto result = run(ranks, "imm-eval", arguments);
      ASSERT_TRUE(result.exit_code == 0 || result.exit_code == 5 || result.exit_code == 7)
          << result.err;
      exit_codes[ranks] = result.exit_code;
      std::string text = testing::slurp(out / "metrics.json");
      // The command line names the folder: everything else must agree.
      const auto command = text.find("\"command\"");
      ASSERT_NE(command, std::string::npos);
      text.erase(command, text.find('\n', command) - command);
      metrics[ranks] = text;
      headline[ranks] = testing::slurp(out / "headline.json");
      EXPECT_FALSE(headline[ranks].empty());
      if (ranks > 0) {
        EXPECT_EQ(metrics[ranks], metrics[0]) << ranks << " ranks";
        EXPECT_EQ(headline[ranks], headline[0]) << ranks << " ranks";
        EXPECT_EQ(exit_codes[ranks], exit_codes[0]) << ranks << " ranks";
      }
    }
  }
  // The other ranks' scratch folders are gone.
  for (const auto& entry : fs::directory_iterator(fs::temp_directory_path())) {
    EXPECT_EQ(entry.path().filename().string().rfind("imm-eval-rank-", 0), std::string::npos)
        << entry.path();
  }
}

TEST_F(Mpi, SweepWithABrokenJobFinishesTheOthersAndNamesIt) {
  const testing::TempDir dir;
  const SmallGa ga(dir, 4);
  // A config the GA refuses (a population of one) for the middle seed's job.
  std::string broken = testing::slurp(ga.config);
  broken.replace(broken.find("population = 24"), 15, "population = 1");
  testing::write_text(dir / "broken.toml", broken);
  testing::write_text(
      dir / "sweep.toml",
      "[[jobs]]\nkind = \"ga\"\nconfig = \"" + ga.config.string() + "\"\nregimes = [\"" +
          ga.regime.string() + "\"]\nseeds = [1, 3]\nout = \"" +
          (dir / "out/{kind}_{regime}_{seed}.h5").string() +
          "\"\n\n[[jobs]]\nkind = \"ga\"\nconfig = \"" + (dir / "broken.toml").string() +
          "\"\nseeds = [2]\nout = \"" + (dir / "out/broken_{seed}.h5").string() + "\"\n");
  for (int ranks : {0, 2, 3}) {
    SCOPED_TRACE(std::to_string(ranks) + " ranks");
    fs::remove_all(dir / "out");
    const auto result =
        run(ranks, "imm-train", {"sweep", "--config", (dir / "sweep.toml").string()});
    EXPECT_EQ(result.exit_code, 3) << result.err;
    EXPECT_NE(result.err.find("1 of 3 trainings failed"), std::string::npos) << result.err;
    EXPECT_NE(result.err.find("ga broken, seed 2 FAILED"), std::string::npos) << result.err;
    EXPECT_NE(result.err.find("population"), std::string::npos) << result.err;
    EXPECT_FALSE(fs::exists(dir / "out/broken_2.h5"));
    for (int seed : {1, 3}) {
      const fs::path model = dir / ("out/ga_ga_imm_training_" + std::to_string(seed) + ".h5");
      ASSERT_TRUE(fs::exists(model)) << model;
      // The same model as the subcommand trains alone.
      const fs::path alone = dir / ("alone" + std::to_string(seed) + ".h5");
      if (!fs::exists(alone)) {
        std::vector<std::string> arguments = ga.arguments(alone);
        arguments.insert(arguments.end(), {"--seed", std::to_string(seed)});
        ASSERT_EQ(run(0, "imm-train", arguments).exit_code, 0);
      }
      EXPECT_EQ(model_contents(model), model_contents(alone));
    }
  }
  // A plan that names a missing config is refused before anything trains, naming the key.
  testing::write_text(dir / "bad.toml",
                      "[[jobs]]\nkind = \"ga\"\nconfig = \"missing.toml\"\n"
                      "out = \"x.h5\"\n");
  const auto refused = run(0, "imm-train", {"sweep", "--config", (dir / "bad.toml").string()});
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("jobs[0].config"), std::string::npos) << refused.err;
}

TEST_F(Mpi, ARankKilledMidRunEndsTheJobWithAnErrorAndNoModel) {
  const testing::TempDir dir;
  const SmallGa ga(dir, 400);
  const fs::path out = dir / "killed.h5";
  std::vector<std::string> launch{"-np", "2", "--oversubscribe",
                                  testing::tool_path("imm-train").string()};
  const auto arguments = ga.arguments(out);
  launch.insert(launch.end(), arguments.begin(), arguments.end());
  const fs::path err = dir / "mpirun.err";
  const pid_t mpirun = testing::start_tool(kMpiexec, launch, "/dev/null", err.string());
  ASSERT_GT(mpirun, 0);
  // The ranks are mpirun's children (a rank's temporaries guard is not: it is adopted by init);
  // rank 1 is the newer one. Wait until the job trains, then kill it.
  const fs::path checkpoint = dir / "killed.h5.checkpoint";
  for (int wait = 0; wait < 20000 && !fs::exists(checkpoint); ++wait) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_TRUE(fs::exists(checkpoint)) << "the job never started: " << testing::slurp(err);
  const auto pids =
      testing::run_tool("/usr/bin/pgrep", {"-n", "-P", std::to_string(mpirun), "-f", out.string()},
                        fs::current_path());
  ASSERT_EQ(pids.exit_code, 0);
  ASSERT_EQ(::kill(std::stoi(pids.out), SIGKILL), 0);
  int status = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (::waitpid(mpirun, &status, WNOHANG) == 0) {
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "the job did not end";
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_FALSE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "the job reported success";
  const std::string message = testing::slurp(err);
  EXPECT_NE(message.find("signal 9"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(out)) << "a model from a job that lost a rank";
  // What stays: the checkpoint (for --resume). A temporary being written is removed by the guard
  // process once its rank is gone.
  std::vector<std::string> others;
  for (int wait = 0; wait < 500; ++wait) {
    others.clear();
    for (const auto& entry : fs::directory_iterator(dir.path())) {
      const std::string name = entry.path().filename().string();
      if (name.rfind("killed", 0) == 0 && name != "killed.h5.checkpoint") others.push_back(name);
      if (name.rfind(".killed", 0) == 0) others.push_back(name);
    }
    if (others.empty()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_TRUE(others.empty()) << others.front();
}

// The nightly with its candidates trained in one sweep over two ranks: the same decisions and the
// same promoted models (to the bit, but for their timestamps) as stage by stage; a broken stage
// fails alone; each training's full log is in its stage's log whichever rank ran it.
TEST_F(Mpi, NightlyTrainsItsCandidatesInOneSweepOverTheRanks) {
  const testing::TempDir dir;
  const SmallGa ga(dir);
  testing::write_text(dir / "cv3.toml", testing::slurp("configs/track/cv3_imm.toml"));
  auto plan = [&](const std::string& name) {
    const fs::path registry = dir / name;
    const fs::path file = dir / (name + ".toml");
    testing::write_text(
        file, "registry = \"" + registry.string() + "\"\nallow_dirty_trainer = true\n\n" +
                  "[[models]]\nname = \"ga\"\ncommand = \"ga\"\nconfig = \"" + ga.config.string() +
                  "\"\nregime = \"" + ga.regime.string() + "\"\nout = \"" +
                  (registry / "ga.h5").string() + "\"\n\n" +
                  "[[models]]\nname = \"broken\"\ncommand = \"freeze\"\nconfig = \"" +
                  (dir / "missing.toml").string() + "\"\nout = \"" +
                  (registry / "broken.h5").string() + "\"\n\n" +
                  "[[models]]\nname = \"cv3\"\ncommand = \"freeze\"\nconfig = \"" +
                  (dir / "cv3.toml").string() + "\"\nout = \"" + (registry / "cv3.h5").string() +
                  "\"\n\n[[evaluations]]\nexperiment = \"plain-imm\"\nmodel = \"cv3\"\nout = \"" +
                  (dir / name / "cv3_report").string() +
                  "\"\nregime = \"configs/regimes/paper/ga_imm_table3.toml\"\nruns = 20\n");
    return file;
  };
  const auto nightly = [&](const std::string& name, std::vector<std::string> extra) {
    std::vector<std::string> arguments = {"all", "--config", plan(name).string(), "--reports",
                                          (dir / (name + "_reports")).string()};
    arguments.insert(arguments.end(), extra.begin(), extra.end());
    return run(0, "imm-train", arguments);
  };
  const auto stages = nightly("stages", {});
  ASSERT_EQ(stages.exit_code, 3) << stages.err;
  const auto swept =
      nightly("swept", {"--launcher", std::string(kMpiexec) + " -np 2 --oversubscribe"});
  ASSERT_EQ(swept.exit_code, 3) << swept.err;

  const std::string report = testing::slurp(dir / "swept_reports" / "latest" / "index.md");
  EXPECT_NE(report.find("Training: 3 candidates trained in one sweep over 2 ranks"),
            std::string::npos)
      << report;
  const std::string alone = testing::slurp(dir / "stages_reports" / "latest" / "index.md");
  for (const char* row :
       {"| model | ga | promoted (first in the manifest) |", "| model | broken | failed |",
        "| model | cv3 | promoted (first in the manifest) |",
        "| evaluation | plain-imm cv3 | ok |"}) {
    EXPECT_NE(report.find(row), std::string::npos) << row << "\n" << report;
    EXPECT_NE(alone.find(row), std::string::npos) << row << "\n" << alone;
  }
  for (const char* model : {"ga.h5", "cv3.h5"}) {
    EXPECT_EQ(model_contents(dir / "swept" / model), model_contents(dir / "stages" / model))
        << model;
  }
  const fs::path logs = dir / "swept_reports" / "latest" / "logs";
  EXPECT_NE(testing::slurp(logs / "model_ga.err").find("level"), std::string::npos);
  EXPECT_NE(testing::slurp(logs / "model_ga.err").find(" info "), std::string::npos);
  EXPECT_EQ(testing::slurp(logs / "model_ga.err").find("[rank"), std::string::npos);
  EXPECT_NE(testing::slurp(logs / "model_broken.err").find("missing.toml"), std::string::npos);
}

}  // namespace
}  // namespace imm
