// SPDX-License-Identifier: Apache-2.0
// Kill -9 drills for every trainer: each is started on a small config and killed with SIGKILL at
// 8 seeded random moments (20 under make test-long) spread over its uninterrupted run time (a few
// land after it finished).
// After every kill the output folder holds nothing partial: no file under the model's name unless
// it is the complete model (identical to an uninterrupted run's), and nothing beside it (a file
// being written at the kill leaves a hidden temporary that the trainer's guard process removes
// when the trainer is gone; see imm/trainer/temporaries_guard.hpp). The GA, which checkpoints,
// resumes after every kill to the identical model. (A GA whose quality gate fails leaves neither
// model nor checkpoint: GaTrainer.FailedGateLeavesNeitherModelNorCheckpoint.)

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "imm/io/container_file.hpp"
#include "testing/regime_files.hpp"
#include "testing/run_tool.hpp"
#include "testing/study.hpp"
#include "testing/temp_dir.hpp"

namespace imm {
namespace {

namespace fs = std::filesystem;
using Replacements = std::vector<std::pair<std::string, std::string>>;

struct Drill {
  std::string trainer;        ///< imm-train subcommand
  std::string config;         ///< shipped config it starts from
  Replacements config_edits;  ///< exact text replacements making it small
  std::string regime;         ///< paper preset (configs/regimes/paper/<name>.toml)
  Replacements regime_edits;
  bool resumable = false;  ///< keeps a checkpoint and takes --resume
};

std::ostream& operator<<(std::ostream& out, const Drill& drill) { return out << drill.trainer; }

fs::path edited_copy(const fs::path& from, const fs::path& to, const Replacements& edits) {
  std::string text = testing::slurp(from);
  for (const auto& [old_text, new_text] : edits) {
    const auto at = text.find(old_text);
    if (at == std::string::npos)
      throw std::runtime_error(from.string() + ": no '" + old_text + "'");
    text.replace(at, old_text.size(), new_text);
  }
  testing::write_text(to, text);
  return to;
}

/// Every dataset of a model file (the provenance attributes carry dates, the data do not).
std::vector<std::pair<std::string, std::vector<double>>> model_data(const fs::path& path) {
  const io::ContainerReader reader(path, "immtrain-model");
  std::vector<std::pair<std::string, std::vector<double>>> data;
  for (const std::string& object : reader.objects()) {
    if (reader.kind(object) == io::ObjectKind::kDataset) {
      data.emplace_back(object, reader.read(object).values);
    }
  }
  return data;
}

/// The files in `folder` other than the model, its metrics and (for a resumable trainer) its
/// checkpoint.
std::vector<std::string> leftovers(const fs::path& folder, bool resumable) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(folder)) {
    const std::string name = entry.path().filename().string();
    if (name == "m.h5" || name == "m.metrics.json" || (resumable && name == "m.h5.checkpoint")) {
      continue;  // the outputs (each written by rename) and the checkpoint
    }
    names.push_back(name);
  }
  return names;
}

class KillDrill : public ::testing::TestWithParam<Drill> {};

TEST_P(KillDrill, KillsLeaveNothingPartial) {
  const Drill& drill = GetParam();
  const testing::TempDir dir;
  const fs::path regime = testing::write_preset_variant(dir, drill.regime, drill.regime_edits);
  const fs::path config =
      edited_copy(drill.config, dir / (drill.trainer + ".toml"), drill.config_edits);
  auto arguments = [&](const fs::path& out, bool resume) {
    std::vector<std::string> a{drill.trainer,   "--config", config.string(), "--regime",
                               regime.string(), "--out",    out.string()};
    if (drill.resumable) a.insert(a.end(), {"--threads", "1"});  // the GA's own threads
    if (resume) a.emplace_back("--resume");
    return a;
  };

  // The kill moments are drawn within the fastest of three uninterrupted runs: on a loaded machine
  // one slow reference run would put many kills after a faster run has already finished.
  double seconds = std::numeric_limits<double>::infinity();
  for (int run = 0; run < 3; ++run) {
    const fs::path folder = dir / ("reference" + std::to_string(run));
    fs::create_directories(folder);
    const auto start = std::chrono::steady_clock::now();
    const auto reference =
        testing::run_tool("imm-train", arguments(folder / "m.h5", false), fs::current_path());
    seconds = std::min(
        seconds, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    ASSERT_EQ(reference.exit_code, 0) << reference.err;
  }
  const auto expected = model_data(dir / "reference0" / "m.h5");
  EXPECT_EQ(model_data(dir / "reference1" / "m.h5"), expected) << "training is not deterministic";

  std::mt19937_64 random(std::hash<std::string>{}(drill.trainer));
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int killed = 0, finished = 0, temporaries = 0, resumed = 0;
  const int kills = testing::quick_or_study(8, 20);  // make test-long: 20
  for (int k = 0; k < kills; ++k) {
    SCOPED_TRACE("kill " + std::to_string(k));
    const fs::path folder = dir / ("kill" + std::to_string(k));
    fs::create_directories(folder);
    const fs::path model = folder / "m.h5";
    const auto start = std::chrono::steady_clock::now();
    const pid_t pid = testing::spawn_tool("imm-train", arguments(model, false));
    ASSERT_GT(pid, 0);
    std::this_thread::sleep_for(std::chrono::duration<double>(unit(random) * seconds));
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    if (WIFSIGNALED(status)) {
      ++killed;
    } else {
      ++finished;
      ASSERT_EQ(WEXITSTATUS(status), 0);
      // It ran faster than the references (they ran beside other tests, this one alone): the
      // later kill moments are drawn within the time by which it had finished.
      seconds = std::min(
          seconds, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    }
    // Under the model's name: nothing, or the complete model.
    if (fs::exists(model)) {
      EXPECT_EQ(model_data(model), expected) << "a partial model";
    }
    // Beside it: nothing. A file being written at the kill leaves its hidden temporary, which the
    // trainer's guard process removes as soon as the trainer is gone (asynchronously: wait for it).
    std::vector<std::string> left = leftovers(folder, drill.resumable);
    if (!left.empty()) ++temporaries;
    for (int wait = 0; wait < 500 && !left.empty(); ++wait) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      left = leftovers(folder, drill.resumable);
    }
    EXPECT_TRUE(left.empty()) << "left beside the output: " << left.front();
    if (WIFSIGNALED(status) && drill.resumable) {
      // The next run continues from the checkpoint to the identical model.
      const auto again = testing::run_tool(
          "imm-train", arguments(model, drill.resumable && fs::exists(folder / "m.h5.checkpoint")),
          fs::current_path());
      ASSERT_EQ(again.exit_code, 0) << again.err;
      if (again.err.find("resuming level") != std::string::npos) ++resumed;
      EXPECT_EQ(model_data(model), expected) << "the rerun differs from an uninterrupted run";
      EXPECT_TRUE(leftovers(folder, false).empty()) << leftovers(folder, false).front();
    }
  }
  std::cout << drill.trainer << ": uninterrupted " << seconds << " s; " << kills
            << " kills: " << killed << " killed, " << finished << " finished first, " << temporaries
            << " caught writing (temporary removed by the guard), " << resumed
            << " resumed from a checkpoint\n";
  EXPECT_GT(killed, kills / 2) << "most kills should land during training";
  if (drill.resumable) {
    EXPECT_GT(resumed, 0) << "no kill landed after a checkpoint";
  }
}

INSTANTIATE_TEST_SUITE_P(
    Trainers, KillDrill,
    ::testing::Values(Drill{"ga",
                            "configs/ga_fuzzy_imm.toml",
                            {{"population = 500", "population = 24"},
                             {"generations = 100", "generations = 12"}},
                            "ga_imm_training",
                            {{"scans = 160", "scans = 60"},
                             {"training = 9 ", "training = 2 "},
                             {"validation = 6", "validation = 1"}},
                            true},
                      Drill{"mlp",
                            "configs/mlp_input_estimator.toml",
                            {{"epochs = 3000", "epochs = 150"}, {"epochs = 3000", "epochs = 150"}},
                            "input_estimator_training",
                            {{"scans = 500", "scans = 200"}}},
                      Drill{"wimm",
                            "configs/wimm.toml",
                            {{"max_evaluations = 150", "max_evaluations = 40"}},
                            "wimm_training",
                            {{"scans = 250", "scans = 120"},
                             {"training = 24", "training = 4"},
                             {"validation = 8", "validation = 2"}}},
                      Drill{"fcm",
                            "configs/fcm_imm.toml",
                            {{"max_evaluations = 150", "max_evaluations = 10"}},
                            "fcm_imm_training",
                            {{"scans = 300", "scans = 120"},
                             {"training = 16", "training = 2"},
                             {"validation = 8", "validation = 1"}}},
                      Drill{"tsk",
                            "configs/tsk_range_sensor.toml",
                            {{"restarts = 10", "restarts = 3"},
                             {"max_iterations = 300", "max_iterations = 100"},
                             {"fine_tuning_iterations = 200", "fine_tuning_iterations = 40"}},
                            "fimm_table1",
                            {{"samples = 8000", "samples = 1500"}}}),
    [](const ::testing::TestParamInfo<Drill>& param_info) { return param_info.param.trainer; });

}  // namespace
}  // namespace imm
