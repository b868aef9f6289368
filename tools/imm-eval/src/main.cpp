// SPDX-License-Identifier: Apache-2.0
// imm-eval: Monte Carlo evaluations of the learned filters against their baselines on the test
// split of a regime, every filter on identical plots; prints the tables with their Monte Carlo
// uncertainty, writes metrics.json, details.json, CSV time series and PNG plots.
//
//   imm-eval <experiment> [--models models/] [--model NAME|PATH] [--regime FILE] [--runs N]
//                         [--seed N] [--out reports/<experiment>/]
//
// experiments: plain-imm, ga-imm, input-estimator, wimm, fcm-imm, fimm (one file each under
// tools/imm-eval/src/; `imm-eval <experiment> --help` lists its own options). Without --regime the
// model is evaluated on the regime recorded in it.
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

#include <CLI/CLI.hpp>
#include <iostream>

#include "imm/evaluation/evaluation_report.hpp"
#include "imm/evaluation/experiment.hpp"
#include "imm/evaluation/headline.hpp"
#include "imm/support/cli.hpp"

int main(int argc, char** argv) {
  CLI::App app{"Monte Carlo evaluation of immtrain filters against their baselines."};
  imm::support::standard_options(app, "imm-eval");
  app.require_subcommand(1);
  int exit_code = 1;
  imm::evaluation::add_plain_imm_command(app, exit_code);
  imm::evaluation::add_ga_imm_command(app, exit_code);
  imm::evaluation::add_input_estimator_command(app, exit_code);
  imm::evaluation::add_wimm_command(app, exit_code);
  imm::evaluation::add_fcm_imm_command(app, exit_code);
  imm::evaluation::add_fimm_command(app, exit_code);
  imm::evaluation::add_regression_command(app, exit_code);
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
