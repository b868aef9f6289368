// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The experiments of one model file, each described once: its name (imm-eval's subcommand), the
/// model kind it evaluates, its line of help, whether it takes the classical bar, its own options
/// and its two halves (experiments.hpp). imm-eval's command line and the Python module's
/// evaluate() are both made from this list, so an experiment added here is a subcommand and a
/// keyword call at once:
///
///   imm::evaluation::for_each_model_experiment([](const auto& experiment) {
///     std::cout << experiment.name << ": " << experiment.about << '\n';
///   });

#include <filesystem>
#include <string>
#include <vector>

#include "imm/evaluation/experiments.hpp"

namespace imm::evaluation {

/// Where an experiment declares its own options (besides CommonOptions): a front end implements
/// it to read them (imm-eval: as command-line options, the Python module: as keywords) or to
/// write them (the command line that report.md records).
class OptionDeclarer {
 public:
  virtual ~OptionDeclarer() = default;
  /// A text option: `flag` on the command line ("--gate-on"), `key` as a keyword ("gate_on").
  /// `choices`: the values allowed (empty: any).
  virtual void text(const char* flag, const char* key, const char* help, std::string& value,
                    const std::vector<std::string>& choices) = 0;
  /// A file or folder option.
  virtual void path(const char* flag, const char* key, const char* help,
                    std::filesystem::path& value) = 0;
};

/// One experiment of one model file (see the file comment).
template <class OptionsType, class ResultType>
struct ModelExperiment {
  using Options = OptionsType;
  using Result = ResultType;
  const char* name;        ///< imm-eval's subcommand and the result's `experiment`: "ga-imm"
  const char* model_kind;  ///< the model kind (imm/model_kinds.hpp) of the file it evaluates
  const char* about;       ///< one line of help
  bool classical_bar;      ///< whether it takes --classical (the FIMM's bar is its own)
  /// Declares its own options on `declarer`, bound to `options` (nullptr: it has none).
  void (*declare)(OptionDeclarer& declarer, Options& options);
  Result (*evaluate)(const Options&);
  int (*report)(const Result&, const Options&);
};

/// Calls `f` with each experiment of one model file (a ModelExperiment of that experiment's own
/// types), in imm-eval's order.
template <class F>
void for_each_model_experiment(F&& f) {
  f(ModelExperiment<PlainImmOptions, PlainImmResult>{
      "plain-imm", "plain_imm", "a plain IMM model on a regime's test tracks vs. its modes alone",
      true,
      [](OptionDeclarer& d, PlainImmOptions& o) {
        d.text("--data", "data", "evaluate a stored data-set file (imm-data tracks) instead",
               o.data, {});
      },
      evaluate_plain_imm, report_plain_imm});
  f(ModelExperiment<GaImmOptions, GaImmResult>{
      "ga-imm", "ga_fuzzy_imm",
      "seed 000 Table 3: GA-fuzzy IMM vs AIMM3/5, tuned AIMM, tuned IMM, the paper's tables", true,
      [](OptionDeclarer& d, GaImmOptions& o) {
        d.text("--paper-model", "paper_model",
               "the paper's tables, in --models (imm-train import-rules)", o.paper_model, {});
      },
      evaluate_ga_imm, report_ga_imm});
  f(ModelExperiment<InputEstimatorOptions, InputEstimatorResult>{
      "input-estimator", "mlp_input_estimator",
      "seed 001 Tables 1-2: neural input estimator vs the constant-velocity KF", true, nullptr,
      evaluate_input_estimator, report_input_estimator});
  f(ModelExperiment<WimmOptions, WimmResult>{
      "wimm", "wimm", "seed 004 Table 2: weighted IMM vs normal IMM and a tuned normal IMM", true,
      nullptr, evaluate_wimm, report_wimm});
  f(ModelExperiment<FcmImmOptions, FcmImmResult>{
      "fcm-imm", "fcm_imm",
      "seed 003 Fig. 5-8: FCM-IMM vs KF, AIMM, tuned IMM and the constant-membership ablation",
      true, nullptr, evaluate_fcm_imm, report_fcm_imm});
  f(ModelExperiment<FimmOptions, FimmResult>{
      "fimm", "tsk_sensor", "seed 002 Table 1: FIMM (TSK sensor model, EKF and IEKF) vs the IMM",
      false,
      [](OptionDeclarer& d, FimmOptions& o) {
        d.path("--config", "config", "TSK config: the FIMM's settings ([fimm])", o.config);
        d.text("--gate-on", "gate_on", "ekf: gate the FIMM (EKF); best: the better of EKF and IEKF",
               o.gate_on, {"ekf", "best"});
      },
      evaluate_fimm, report_fimm});
}

/// The names of the experiments of one model file, in imm-eval's order.
[[nodiscard]] inline std::vector<std::string> model_experiment_names() {
  std::vector<std::string> names;
  for_each_model_experiment([&](const auto& experiment) { names.emplace_back(experiment.name); });
  return names;
}

}  // namespace imm::evaluation
