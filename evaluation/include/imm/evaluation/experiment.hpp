// SPDX-License-Identifier: Apache-2.0
#pragma once
/// What every `imm-eval` experiment shares: the command line (--models, --model, --regime, --runs,
/// --seed, --out), the regime it evaluates on and the checks that a model may run on it, and the
/// tracks it draws.
///
/// The regime is --regime, or the one recorded in the model file. A model is refused on a regime
/// that differs in something the model is built for — the sample period, the unit, the sensor and
/// its noise — with a message naming the field; a model evaluated on a regime other than the one
/// it was trained for (other maneuvers, another start) runs, and the report says so. The test
/// split is drawn from --seed; the baselines are tuned on the training split of the model's own
/// regime — the tracks the learned model saw — never on the test tracks.
///
/// Each experiment is one file: its run and its report (experiments.hpp); the commands are in
/// tools/imm-eval.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "imm/datasets/regime_file.hpp"
#include "imm/datasets/track.hpp"
#include "imm/io/model_file.hpp"
#include "imm/support/exit_codes.hpp"

namespace imm::evaluation {

struct CommonOptions {
  std::filesystem::path models = "models";
  std::string model;  ///< a file in --models (".h5" optional) or a path
  std::optional<std::filesystem::path> regime;
  std::optional<int> runs;  ///< test tracks (default: the regime's test split)
  std::uint64_t seed = 1;
  std::filesystem::path out;
  /// --truth-tracks: only the test tracks that carry truth (a recorded set with truth for some
  /// recordings), judged by their errors.
  bool truth_tracks = false;
  /// --classical: the regime's tuned CV/CA/CT IMM (classical_bar.hpp) as `imm-train baseline`
  /// wrote it; without it the experiment tunes that filter itself.
  std::optional<std::filesystem::path> classical;

  /// The model file: `model` if it names an existing path, else models/model(.h5).
  [[nodiscard]] std::filesystem::path model_path() const;
  /// Options whose model and report folder are `model` and `out` (an experiment's defaults).
  [[nodiscard]] static CommonOptions defaults(std::string model, std::filesystem::path out) {
    CommonOptions options;
    options.model = std::move(model);
    options.out = std::move(out);
    return options;
  }
};

/// A --regime value: a regime TOML, or a model file (.h5) whose recorded regime is meant (so a
/// candidate and the shipped model are evaluated on the same tracks).
[[nodiscard]] datasets::RegimeFile load_regime_option(const std::filesystem::path& path);

/// The regimes of one evaluation.
struct EvaluationRegimes {
  datasets::RegimeFile evaluated;  ///< where the test tracks come from
  datasets::RegimeFile trained;    ///< the model's own (its training split tunes the baselines)
  /// The evaluated regime is not the one the model was trained for.
  [[nodiscard]] bool off_training() const {
    return evaluated.regime.digest != trained.regime.digest;
  }
  /// One line for the report: which regime, and whether it is the model's own.
  [[nodiscard]] std::string describe() const;
};

/// --regime (or the model's), and the model's own regime. std::runtime_error when the model
/// records none.
[[nodiscard]] EvaluationRegimes evaluation_regimes(const CommonOptions& options,
                                                   const io::Provenance& model,
                                                   const std::filesystem::path& path);

/// Another model on an already chosen regime (a second model of the same experiment).
[[nodiscard]] EvaluationRegimes evaluation_regimes(const datasets::RegimeFile& evaluated,
                                                   const io::Provenance& model,
                                                   const std::filesystem::path& path);

/// What a model is built for, checked against the evaluated regime: the sample period, the unit,
/// the sensor kind, and the plot σ when given (per axis; the model's R; a recorded regime's
/// estimated σ within 10 % of it). Throws
/// std::runtime_error "model M: sample_period 2 s differs from regime R's 1 s" naming the field.
struct ModelRequirements {
  double sample_period = 0.0;
  std::optional<datasets::SensorKind> sensor;
  std::optional<double> plot_sigma;  ///< Cartesian: σ per axis; polar: σ_r (with azimuth_sigma)
  std::optional<double> azimuth_sigma;
};
void check_model(const ModelRequirements& model, const EvaluationRegimes& regimes,
                 const std::filesystem::path& path);

/// check_model's first questions, for a model that may record no regime: why a model built for
/// `sample_period` s, with lengths in `length_unit` ("" where its file does not say) and, when
/// given, for a `sensor` cannot read `regime`'s plots — "sample_period: …", "units: …" or
/// "sensor.kind: …" — or "" where it can.
[[nodiscard]] std::string plots_mismatch(double sample_period, std::string_view length_unit,
                                         std::optional<datasets::SensorKind> sensor,
                                         const datasets::Regime& regime);

/// The test tracks (--runs of them, or the regime's test split) of --seed. A recorded regime's
/// tracks may lack truth (has_truth false: every experiment then judges by the plots); where some
/// have it, --truth-tracks keeps those only (std::runtime_error naming the regime when none has).
[[nodiscard]] datasets::TrackSet test_tracks(const datasets::Regime& regime,
                                             const CommonOptions& options);

/// The filter named `name` among an experiment's results (anything with a `name`).
template <class Outcome>
[[nodiscard]] const Outcome& find_filter(const std::vector<Outcome>& filters,
                                         const std::string& name) {
  for (const Outcome& f : filters) {
    if (f.name == name) return f;
  }
  throw std::logic_error("missing filter " + name);
}

/// A case's name in a report: the scripted case's, or "all tracks" for a random regime.
[[nodiscard]] std::string case_label(const datasets::Regime& regime, int case_index);

/// The tracks of one case of the regime.
struct CaseTracks {
  int index = 0;
  std::string name;  ///< case_label
  datasets::TrackSet tracks;
};
/// `data` split by case, in case order; a case without tracks (fewer runs than cases) is left out.
[[nodiscard]] std::vector<CaseTracks> tracks_by_case(const datasets::Regime& regime,
                                                     const datasets::TrackSet& data);

/// Whether `regime` is one of the papers' own scenarios (a preset of configs/regimes/paper/, by
/// name). There a learned model must reproduce its paper's claim — beat the paper's baseline
/// beyond the uncertainty — and not doing so is a gate failure. On any other regime the gate is
/// that it is not *worse* than the paper's baseline beyond the uncertainty; not beating it is a
/// finding (something learned, reported with its numbers), not something broken.
[[nodiscard]] bool paper_scenario(const datasets::Regime& regime);

/// True when the model's trainer switched its learned part off (`training.learned_part_on` = 0:
/// the learned part did not pay, by the trainer's own rule), so the model is its tuned classical
/// baseline; reports say so beside their verdicts.
[[nodiscard]] bool learned_part_off(const io::Provenance& provenance);

/// The closing lines of a report: where it went, the gate failures on stderr (unless printed
/// already), and the exit code: kEvaluationGateFailed when a gate failed (something is broken: the
/// learned model is worse than a paper baseline), else kFindings when there are findings (the
/// learned model does not beat a baseline tuned on its regime — reported, not a failure), else 0.
int finish_report(const std::filesystem::path& out, bool plotted,
                  const std::vector<std::string>& failures, bool failures_printed = false,
                  const std::vector<std::string>& findings = {});

/// Prints the findings block of a report ("Findings (…): none" or one line each), after the gates.
void print_findings(const std::vector<std::string>& findings);

}  // namespace imm::evaluation
