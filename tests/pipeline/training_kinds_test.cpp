// SPDX-License-Identifier: Apache-2.0
// The training subcommands described once (training_commands.hpp): imm-train's command line and a
// sweep's jobs find each kind, its options and its model kind there.
#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <string>
#include <vector>

#include "imm/model_kinds.hpp"
#include "imm/pipeline/sweep.hpp"
#include "imm/pipeline/training_commands.hpp"
#include "imm/support/config.hpp"
#include "testing/temp_dir.hpp"

namespace imm::pipeline {
namespace {

// `arguments` parsed as imm-train's command line of training subcommands.
struct Parsed {
  CLI::App app{"imm-train"};
  TrainingCommands training{app};
  explicit Parsed(std::vector<std::string> arguments) {
    std::reverse(arguments.begin(), arguments.end());
    app.parse(arguments);
  }
};

TEST(TrainingKinds, EachNamesARegisteredModelKindAndIsFoundByItsNames) {
  ASSERT_FALSE(training_kinds().empty());
  for (const TrainingKind& kind : training_kinds()) {
    SCOPED_TRACE(kind.command);
    EXPECT_FALSE(kind.about.empty());
    if (!kind.model_kind.empty()) {
      const ModelKind* written = find_model_kind(kind.model_kind);
      ASSERT_NE(written, nullptr);
      EXPECT_EQ(written->name, kind.model_kind);
    }
    const TrainingKind* found = find_training_kind(kind.command);
    EXPECT_EQ(found, kind.training_options ? &kind : nullptr);
  }
  // A kind whose command is an alias of its model kind answers to every name of that kind.
  for (const char* name : {"ga_fuzzy_imm", "ga-imm", "ga"}) {
    ASSERT_NE(find_training_kind(name), nullptr) << name;
    EXPECT_EQ(find_training_kind(name)->command, "ga");
  }
  ASSERT_NE(find_training_kind("tsk_sensor"), nullptr);
  EXPECT_EQ(find_training_kind("tsk_sensor")->command, "tsk");
  // freeze and import-rules take no training options; a name of no kind finds nothing.
  EXPECT_EQ(find_training_kind("freeze"), nullptr);
  EXPECT_EQ(find_training_kind("import-rules"), nullptr);
  EXPECT_EQ(find_training_kind("gaa"), nullptr);
  EXPECT_EQ(find_training_kind(""), nullptr);
}

TEST(TrainingKinds, TheCommandLineChoosesOneAndKnowsItsOutput) {
  {
    const Parsed parsed({"ga", "--threads", "2", "--resume"});
    ASSERT_NE(parsed.training.chosen(), nullptr);
    EXPECT_EQ(parsed.training.chosen()->command, "ga");
    EXPECT_TRUE(parsed.training.chosen()->distributed);
    EXPECT_EQ(parsed.training.chosen_out(), std::filesystem::path("models/ga_fuzzy_imm.h5"));
  }
  {
    const Parsed parsed({"tsk", "--data", "samples.csv", "--out", "o/t.h5", "--seed", "3"});
    ASSERT_NE(parsed.training.chosen(), nullptr);
    EXPECT_EQ(parsed.training.chosen()->command, "tsk");
    EXPECT_FALSE(parsed.training.chosen()->distributed);
    EXPECT_EQ(parsed.training.chosen_out(), std::filesystem::path("o/t.h5"));
  }
  {
    const Parsed parsed({"freeze", "--config", "c.toml", "--out", "f.h5"});
    EXPECT_EQ(parsed.training.chosen_out(), std::filesystem::path("f.h5"));
  }
  // Options of one subcommand are not another's; a baseline must say where it writes.
  EXPECT_THROW(Parsed({"mlp", "--data", "x.csv"}), CLI::ParseError);
  EXPECT_THROW(Parsed({"baseline", "--config", "c.toml"}), CLI::ParseError);
  EXPECT_THROW(Parsed({"import-rules", "--out", "x.h5"}), CLI::ParseError);
  // No training subcommand: nothing chosen, and run() says so.
  CLI::App app{"imm-train"};
  const TrainingCommands none(app);
  app.add_subcommand("other", "");
  std::vector<std::string> other{"other"};
  app.parse(other);
  EXPECT_EQ(none.chosen(), nullptr);
  EXPECT_FALSE(none.chosen_out().has_value());
  EXPECT_THROW((void)none.run(), std::logic_error);
}

TEST(TrainingKinds, ASweepExpandsAKindByAnyOfItsNamesAndRefusesOneWithoutTrainingOptions) {
  const testing::TempDir dir;
  testing::write_text(dir / "c.toml", "");
  const auto plan_of = [&](const std::string& kind) {
    testing::write_text(dir / "plan.toml",
                        "[[jobs]]\nkind = \"" + kind + "\"\nconfig = \"" +
                            (dir / "c.toml").string() +
                            "\"\nseeds = [1, 2]\nout = \"m_{kind}_{seed}.h5\"\n");
    return load_sweep_plan(dir / "plan.toml");
  };
  const SweepPlan ga = plan_of("ga_fuzzy_imm");
  ASSERT_EQ(ga.jobs.size(), 2u);
  EXPECT_EQ(ga.jobs[1].kind, "ga");
  EXPECT_EQ(ga.jobs[1].out, std::filesystem::path("m_ga_2.h5"));
  EXPECT_EQ(ga.jobs[1].arguments,
            (std::vector<std::string>{"ga", "--config", (dir / "c.toml").string(), "--seed", "2",
                                      "--out", "m_ga_2.h5"}));
  // A job of every training kind is a command line of its subcommand.
  for (const TrainingKind& kind : training_kinds()) {
    if (!kind.training_options) continue;
    const SweepPlan plan = plan_of(kind.command);
    ASSERT_EQ(plan.jobs.size(), 2u);
    CLI::App app{"imm-train"};
    const TrainingCommands training(app);
    EXPECT_NO_THROW(parse_job(app, plan.jobs[0])) << kind.command;
    EXPECT_EQ(training.chosen(), &kind);
  }
  try {
    (void)plan_of("freeze");
    ADD_FAILURE() << "a sweep expanded freeze over seeds";
  } catch (const support::ConfigError& error) {
    EXPECT_EQ(error.key(), "jobs[0].kind");
    EXPECT_NE(std::string(error.what()).find("ga, mlp, wimm, fcm, baseline, schedule, tsk"),
              std::string::npos)
        << error.what();
  }
  // The command form takes every training subcommand.
  const std::vector<std::string>& commands = sweep_subcommands();
  EXPECT_EQ(commands.size(), training_kinds().size());
  EXPECT_NE(std::find(commands.begin(), commands.end(), "import-rules"), commands.end());
  EXPECT_EQ(std::find(commands.begin(), commands.end(), "sweep"), commands.end());
}

}  // namespace
}  // namespace imm::pipeline
