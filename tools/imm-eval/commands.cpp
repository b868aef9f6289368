// SPDX-License-Identifier: Apache-2.0
#include "commands.hpp"

#include <exception>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "imm/evaluation/experiments.hpp"
#include "imm/evaluation/model_experiments.hpp"
#include "imm/support/cli.hpp"
#include "imm/support/exit_codes.hpp"

namespace imm::eval_tool {
namespace {

using evaluation::CommonOptions;

// Runs an experiment, turning exceptions into a message and support::exit_code::kBadInput.
int guarded(const std::function<int()>& body) {
  try {
    return body();
  } catch (const std::exception& error) {
    std::cerr << "imm-eval: " << error.what() << '\n';
  } catch (...) {
    std::cerr << "imm-eval: unexpected error\n";
  }
  return support::exit_code::kBadInput;
}

// The options every model experiment shares; their defaults are the options struct's.
void add_common_options(CLI::App& command, CommonOptions& options) {
  command.add_option("--models", options.models, "folder of model files");
  command.add_option("--model", options.model,
                     "model file: a name in --models (default " + options.model + ") or a path");
  command.add_option("--regime", options.regime,
                     "regime TOML to evaluate on, or a model file whose recorded regime to use "
                     "(default: the one recorded in the model)");
  command.add_option("--runs", options.runs, "test tracks (default: the regime's test split)")
      ->check(support::at_least(1));
  command.add_option("--seed", options.seed, "seed of the test tracks")->check(support::seed());
  command.add_option("--out", options.out, "report folder");
  command.add_flag("--truth-tracks", options.truth_tracks,
                   "only the test tracks with truth (a recorded set with truth for some "
                   "recordings), judged by their errors");
}

void add_classical_option(CLI::App& command, CommonOptions& options) {
  command.add_option("--classical", options.classical,
                     "the regime's tuned CV/CA/CT IMM (imm-train baseline --config "
                     "configs/classical_imm.toml) to list as the classical bar (default: tuned "
                     "here on the model's training split, the same search)");
}

// A subcommand whose options live as long as the app; `run` gets them when it is chosen.
template <class Options>
std::pair<CLI::App*, std::shared_ptr<Options>> subcommand(CLI::App& app, const std::string& name,
                                                          const std::string& description,
                                                          int& exit_code,
                                                          int (*run)(const Options&)) {
  auto options = std::make_shared<Options>();
  CLI::App* command = app.add_subcommand(name, description);
  command->callback(
      [options, run, &exit_code] { exit_code = guarded([&] { return run(*options); }); });
  return {command, options};
}

// An experiment's own options as command-line options.
class CommandLineOptions final : public evaluation::OptionDeclarer {
 public:
  explicit CommandLineOptions(CLI::App& command) : command_(command) {}
  void text(const char* flag, const char* /*key*/, const char* help, std::string& value,
            const std::vector<std::string>& choices) override {
    CLI::Option* option = command_.add_option(flag, value, help);
    if (!choices.empty()) option->check(CLI::IsMember(choices));
  }
  void path(const char* flag, const char* /*key*/, const char* help,
            std::filesystem::path& value) override {
    command_.add_option(flag, value, help);
  }

 private:
  CLI::App& command_;
};

// An experiment of one model file (model_experiments.hpp): the shared options, the classical bar
// where it takes one, and its own.
template <class Options, class Result>
void add_model_experiment(CLI::App& app, int& exit_code,
                          const evaluation::ModelExperiment<Options, Result>& experiment) {
  auto options = std::make_shared<Options>();
  CLI::App* command = app.add_subcommand(experiment.name, experiment.about);
  add_common_options(*command, options->common);
  if (experiment.classical_bar) add_classical_option(*command, options->common);
  if (experiment.declare != nullptr) {
    CommandLineOptions declarer(*command);
    experiment.declare(declarer, *options);
  }
  command->callback([options, experiment, &exit_code] {
    exit_code = guarded([&] { return experiment.report(experiment.evaluate(*options), *options); });
  });
}

void add_rank(CLI::App& app, int& exit_code) {
  auto [command, options] = subcommand<evaluation::RankOptions>(
      app, "rank",
      "the regime's tracker: the tuned baseline and the learned models of one regime ranked on "
      "its test split, the winner written with --ship",
      exit_code, evaluation::run_rank);
  command
      ->add_option("--baseline", options->baselines,
                   "the regime's tuned classical filters (imm-train baseline), one or more: the "
                   "best on the test tracks is the bar every learned model faces")
      ->required();
  command
      ->add_option("--candidates", options->candidates,
                   "learned model files trained for the same regime")
      ->required();
  command->add_option(
      "--evaluations", options->evaluations,
      "report folders of the learned models' own experiments (imm-eval <experiment> --out): a "
      "learned model is eligible only when one of them evaluated that very file and passed its "
      "gates");
  command->add_option("--regime", options->regime,
                      "regime TOML (default: the one recorded in the first baseline)");
  command->add_option("--runs", options->runs, "test tracks (default: the regime's test split)")
      ->check(support::at_least(1));
  command->add_option("--seed", options->seed, "seed of the test tracks")->check(support::seed());
  command->add_option("--out", options->out, "report folder");
  command->add_option("--ship", options->ship,
                      "write the winning model file here (atomically), with a covariance "
                      "calibration fitted on the regime's training split");
  command->add_flag("--raw-ship", options->raw_ship,
                    "ship the winner without the covariance calibration");
}

void add_multi_target(CLI::App& app, int& exit_code) {
  auto [command, options] = subcommand<evaluation::MultiTargetOptions>(
      app, "multi-target",
      "several targets of a regime at once in clutter, tracked by the reference GNN tracker with "
      "each model, judged by GOSPA",
      exit_code, evaluation::run_multi_target_experiment);
  command
      ->add_option("--models", options->models,
                   "plain IMM model files (the first: the "
                   "reference of the differences)")
      ->required();
  command->add_option("--regime", options->regime,
                      "regime TOML (default: the one recorded in the first model)");
  command->add_option("--targets", options->targets,
                      "targets per scene (default: the regime's [scene], else 3)");
  command
      ->add_option(
          "--pd", options->detection_probabilities,
          "detection probabilities (one or more: every one with every clutter density; default: "
          "the regime's [scene], else 0.9)")
      ->delimiter(',');
  command
      ->add_option("--clutter", options->clutter_densities,
                   "mean false plots per scan over the scene's region (one or more; default: the "
                   "regime's [scene], else 10)")
      ->delimiter(',');
  command->add_option("--runs", options->settings.runs, "scenes");
  command->add_option("--seed", options->settings.seed, "the scenes' seed")->check(support::seed());
  command->add_option("--out", options->out, "report folder (metrics.json)");
}

void add_regression(CLI::App& app, int& exit_code) {
  struct Options {
    evaluation::RegressionOptions regression;
    std::vector<std::string> relative, absolute;
  };
  auto options = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "regression", "a candidate model's headline metrics vs the shipped model's, same test runs");
  command->add_option("--candidate", options->regression.candidate, "headline.json (or its folder)")
      ->required();
  command->add_option("--shipped", options->regression.shipped, "headline.json (or its folder)")
      ->required();
  command->add_option("--out", options->regression.out, "folder for regression.json");
  command->add_option("--relative-margin", options->relative,
                      "[METRIC=]R: a difference below R × |value| is a tie (repeatable)");
  command->add_option("--absolute-margin", options->absolute,
                      "[METRIC=]A: a difference below A is a tie (repeatable)");
  command->callback([options, &exit_code] {
    exit_code = guarded([&] {
      evaluation::RegressionOptions regression = options->regression;
      for (const auto& r : options->relative) {
        regression.margins.push_back(evaluation::parse_margin(r, true));
      }
      for (const auto& a : options->absolute) {
        regression.margins.push_back(evaluation::parse_margin(a, false));
      }
      return evaluation::run_regression(regression);
    });
  });
}

}  // namespace

void add_commands(CLI::App& app, int& exit_code) {
  evaluation::for_each_model_experiment(
      [&](const auto& experiment) { add_model_experiment(app, exit_code, experiment); });
  add_rank(app, exit_code);
  add_regression(app, exit_code);
  add_multi_target(app, exit_code);
}

}  // namespace imm::eval_tool
