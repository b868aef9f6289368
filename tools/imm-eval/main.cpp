// SPDX-License-Identifier: Apache-2.0
// imm-eval: Monte Carlo evaluations of the learned filters against their baselines on the test
// split of a regime, every filter on identical plots; prints the tables with their Monte Carlo
// uncertainty, writes metrics.json, details.json, CSV time series and PNG plots.
//
//   imm-eval <experiment> [--models models/] [--model NAME|PATH] [--regime FILE] [--runs N]
//                         [--seed N] [--out reports/<experiment>/]
//
// experiments: plain-imm, ga-imm, input-estimator, wimm, fcm-imm, fimm (one file each under
// evaluation/src/, their options and entry points in imm/evaluation/experiments.hpp; the
// commands in commands.cpp; `imm-eval <experiment> --help` lists its own options). Without --regime
// the model is evaluated on the regime recorded in it.
//
// Every experiment writes metrics.json in one shape and report.md (evaluation_report.hpp), and
// headline.json: its headline metrics with their per-run terms.
//   imm-eval regression --candidate DIR --shipped DIR [--out DIR]
// compares two such evaluations on the same runs (the nightly's regression gate).
//
// Exit codes: 0 success, 1 usage, 2 invalid model, regime or data file (or a model that does not
// fit the regime, or two headline files of different runs), 5 a quality gate failed (the report
// is written either way), 6 (regression) the candidate is worse than the shipped model beyond
// the Monte Carlo uncertainty.

#include <fcntl.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "imm/evaluation/evaluation_report.hpp"
#include "imm/io/container_file.hpp"
#include "imm/support/cli.hpp"
#include "imm/support/kind_aliases.hpp"
#include "imm/trainer/ranks.hpp"

namespace {

/// Under mpirun every rank runs the same experiment (the same exchanges, in the same order); the
/// root alone prints and keeps the report. The others print nowhere and write into a folder of
/// their own, removed at the end: their `--out` is replaced.
class ScratchForOtherRanks {
 public:
  explicit ScratchForOtherRanks(std::vector<std::string>& arguments) {
    if (imm::trainer::Ranks::world().root()) return;
    std::string pattern =
        (std::filesystem::temp_directory_path() / "imm-eval-rank-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) return;
    folder_ = pattern;
    const auto out = std::find(arguments.begin(), arguments.end(), "--out");
    if (out != arguments.end() && out + 1 != arguments.end()) {
      *(out + 1) = folder_.string();
    } else {
      arguments.insert(arguments.end(), {"--out", folder_.string()});
    }
    const int null = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
    if (null >= 0) {
      ::dup2(null, STDOUT_FILENO);
      ::close(null);
    }
  }
  ~ScratchForOtherRanks() {
    std::error_code ignored;
    if (!folder_.empty()) std::filesystem::remove_all(folder_, ignored);
  }
  ScratchForOtherRanks(const ScratchForOtherRanks&) = delete;
  ScratchForOtherRanks& operator=(const ScratchForOtherRanks&) = delete;

 private:
  std::filesystem::path folder_;
};

int run(int argc, char** argv) {
  CLI::App app{"Monte Carlo evaluation of immtrain filters against their baselines."};
  imm::support::standard_options(app, "imm-eval");
  app.require_subcommand(1);
  int exit_code = 1;
  imm::eval_tool::add_commands(app, exit_code);
  imm::support::alias_model_kinds(app);
  // Everything an experiment prints also goes into its folder's report.md.
  imm::evaluation::ReportRecorder recorder(argc, argv);
  if (const auto exit = imm::support::parse(app, argc, argv)) return *exit;
  try {
    (void)recorder.finish();
  } catch (const std::exception& error) {
    std::cerr << "imm-eval: report.md: " << error.what() << '\n';
    return 2;
  }
  return exit_code;
}

}  // namespace

int main(int argc, char** argv) {
  imm::io::skip_hdf5_shutdown_at_exit();  // before any HDF5 call (container_file.hpp)
  const imm::trainer::Ranks::Session session(argc, argv);
  std::vector<std::string> arguments(argv, argv + argc);
  int code = 0;
  {
    const ScratchForOtherRanks scratch(arguments);
    std::vector<char*> pointers;
    pointers.reserve(arguments.size());
    for (std::string& argument : arguments) pointers.push_back(argument.data());
    const auto start = std::chrono::steady_clock::now();
    code = run(static_cast<int>(pointers.size()), pointers.data());
    const imm::trainer::Ranks& ranks = imm::trainer::Ranks::world();
    if (ranks.distributed() && ranks.root()) {
      std::cerr << "imm-eval: " << ranks.size() << " ranks: " << ranks.shared_seconds() << " s of "
                << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()
                << " s in the shared Monte Carlo runs; the root sent " << ranks.bytes_sent()
                << " bytes in " << ranks.messages_sent() << " messages, "
                << ranks.exchange_seconds() << " s in exchanges\n";
    }
  }
  // A rank that fails alone must not leave the others waiting in the next exchange; a gate's or
  // the regression's verdict and the findings are the same on every rank.
  if (code != 0 && code != imm::support::exit_code::kEvaluationGateFailed &&
      code != imm::support::exit_code::kRegression && code != imm::support::exit_code::kFindings) {
    imm::trainer::Ranks::world().abort_job(code);
  }
  return code;
}
