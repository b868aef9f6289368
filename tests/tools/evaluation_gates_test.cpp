// SPDX-License-Identifier: Apache-2.0
// What an evaluation folder says of its model's gates, read from hand-written folders: passed,
// FAILED with its failures, no gates at all, and the folders that are not a finished evaluation.
#include "imm/evaluation/evaluation_gates.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "testing/temp_dir.hpp"

namespace imm::evaluation {
namespace {

const std::string kSha(64, 'a');

void write_evaluation(const std::filesystem::path& folder, const std::string& sha,
                      const std::string& report) {
  std::filesystem::create_directories(folder);
  testing::write_text(folder / "metrics.json",
                      R"({"models": [{"role": "paper", "sha256": ")" + std::string(64, 'b') +
                          R"("}, {"role": "evaluated", "sha256": ")" + sha + R"("}]})");
  testing::write_text(folder / "report.md", report);
}

TEST(EvaluationGates, PassedFailedAndNoGatesAreReadWithTheEvaluatedModel) {
  const testing::TempDir dir;
  write_evaluation(dir / "passed", kSha, "| a | b |\nGates (X below Y): passed\nFindings: none\n");
  write_evaluation(dir / "failed", kSha,
                   "Gates (X below Y): FAILED\n  - X is above Y (+1.0 [+0.5, +1.5])\n"
                   "  - X is above Z\nFindings (…): 1\n  - not a gate\n");
  write_evaluation(dir / "none", std::string(64, 'c'), "a table and no gates\n");

  const EvaluationGates passed = read_evaluation_gates(dir / "passed");
  EXPECT_EQ(passed.model_sha256, kSha);
  EXPECT_TRUE(passed.passed);
  EXPECT_EQ(passed.line, "Gates (X below Y): passed");
  const EvaluationGates failed = read_evaluation_gates(dir / "failed");
  EXPECT_FALSE(failed.passed);
  EXPECT_EQ(failed.failures,
            (std::vector<std::string>{"X is above Y (+1.0 [+0.5, +1.5])", "X is above Z"}));
  const EvaluationGates none = read_evaluation_gates(dir / "none");
  EXPECT_TRUE(none.passed);
  EXPECT_TRUE(none.line.empty());

  // One failed evaluation of a file outweighs any number that passed; another file is unchecked.
  const std::vector<EvaluationGates> all{passed, failed, none};
  EXPECT_EQ(gate_standing(kSha, std::vector<EvaluationGates>{passed}).state,
            GateStanding::State::kPassed);
  const GateStanding standing = gate_standing(kSha, all);
  EXPECT_EQ(standing.state, GateStanding::State::kFailed);
  EXPECT_NE(standing.text.find("X is above Y"), std::string::npos) << standing.text;
  EXPECT_NE(standing.text.find("and 1 more"), std::string::npos) << standing.text;
  EXPECT_EQ(gate_standing(std::string(64, 'c'), all).state, GateStanding::State::kPassed);
  EXPECT_EQ(gate_standing(std::string(64, 'd'), all).state, GateStanding::State::kUnchecked);
}

TEST(EvaluationGates, AFolderThatIsNotAFinishedEvaluationIsRefusedNamingTheFile) {
  const testing::TempDir dir;
  const auto refused = [&](const std::string& name, const std::string& what) {
    try {
      (void)read_evaluation_gates(dir / name);
      ADD_FAILURE() << name << " was read";
    } catch (const std::runtime_error& error) {
      EXPECT_NE(std::string(error.what()).find(what), std::string::npos) << error.what();
    }
  };
  std::filesystem::create_directories(dir / "empty");
  refused("empty", "metrics.json: missing");
  write_evaluation(dir / "no_sha", "short", "Gates: passed\n");
  refused("no_sha", "models: names no evaluated model");
  write_evaluation(dir / "unclear", kSha, "Gates (X): maybe\n");
  refused("unclear", "neither passed nor FAILED");
  write_evaluation(dir / "twice", kSha, "Gates (X): passed\nGates (Y): passed\n");
  refused("twice", "more than one Gates line");
  write_evaluation(dir / "not_json", kSha, "Gates (X): passed\n");
  testing::write_text(dir / "not_json" / "metrics.json", "{");
  refused("not_json", "not JSON");
}

}  // namespace
}  // namespace imm::evaluation
