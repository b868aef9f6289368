// SPDX-License-Identifier: Apache-2.0
// The experiments of one model file described once (model_experiments.hpp): imm-eval's
// subcommands and the Python module's evaluate() are made from the list, so what it says must hold
// together.
#include "imm/evaluation/model_experiments.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "imm/model_kinds.hpp"

namespace imm::evaluation {
namespace {

// Every option an experiment declares, with its default value and choices.
struct Declared {
  std::string flag, key, value;
  std::vector<std::string> choices;
};
class Recorder final : public OptionDeclarer {
 public:
  void text(const char* flag, const char* key, const char* help, std::string& value,
            const std::vector<std::string>& choices) override {
    EXPECT_NE(std::string(help), "");
    declared.push_back({flag, key, value, choices});
  }
  void path(const char* flag, const char* key, const char* help,
            std::filesystem::path& value) override {
    EXPECT_NE(std::string(help), "");
    declared.push_back({flag, key, value.string(), {}});
  }
  std::vector<Declared> declared;
};

TEST(ModelExperiments, EachEvaluatesARegisteredKindAndDeclaresItsOptionsConsistently) {
  std::set<std::string> names;
  int count = 0;
  for_each_model_experiment([&](const auto& experiment) {
    ++count;
    SCOPED_TRACE(experiment.name);
    EXPECT_TRUE(names.insert(experiment.name).second) << "a name listed twice";
    const ModelKind* kind = find_model_kind(experiment.model_kind);
    ASSERT_NE(kind, nullptr);
    EXPECT_EQ(kind->name, experiment.model_kind);
    EXPECT_NE(std::string(experiment.about), "");
    ASSERT_NE(experiment.evaluate, nullptr);
    ASSERT_NE(experiment.report, nullptr);
    typename std::remove_cvref_t<decltype(experiment)>::Options options;
    Recorder recorder;
    if (experiment.declare != nullptr) experiment.declare(recorder, options);
    std::set<std::string> keys;
    for (const Declared& d : recorder.declared) {
      // The keyword is the flag without its dashes, '-' read as '_'.
      std::string key = d.flag.substr(2);
      std::replace(key.begin(), key.end(), '-', '_');
      EXPECT_EQ(d.flag.substr(0, 2), "--");
      EXPECT_EQ(d.key, key);
      EXPECT_TRUE(keys.insert(d.key).second) << d.key << " declared twice";
      // A shared option's name is not taken again.
      for (const char* common :
           {"model", "models", "regime", "runs", "seed", "out", "classical", "truth_tracks"}) {
        EXPECT_NE(d.key, common);
      }
      if (!d.choices.empty()) {
        EXPECT_NE(std::find(d.choices.begin(), d.choices.end(), d.value), d.choices.end())
            << d.key << "'s default '" << d.value << "' is none of its choices";
      }
    }
  });
  EXPECT_EQ(count, 6);
  EXPECT_EQ(model_experiment_names(),
            (std::vector<std::string>{"plain-imm", "ga-imm", "input-estimator", "wimm", "fcm-imm",
                                      "fimm"}));
}

}  // namespace
}  // namespace imm::evaluation
