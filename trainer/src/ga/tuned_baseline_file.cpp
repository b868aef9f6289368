// SPDX-License-Identifier: Apache-2.0
#include "imm/trainer/ga/tuned_baseline_file.hpp"

#include <chrono>
#include <nlohmann/json.hpp>

#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/io/model_file.hpp"
#include "imm/trainer/ga/tuned_levels.hpp"
#include "imm/trainer/model_files/write_model.hpp"
#include "imm/trainer/provenance.hpp"
#include "imm/trainer/training_set.hpp"

namespace imm::trainer::ga {

TunedBaselineResult write_tuned_baseline(GaTrainingConfig config,
                                         const std::filesystem::path& out) {
  const auto start = std::chrono::steady_clock::now();
  config.tuned_levels = true;
  config.baseline.reset();
  const TrainingSet training = make_training_set(config.regime, datasets::Split::kTraining);
  config = resolve_levels(std::move(config), training);
  const TunedBaseline& baseline = *config.baseline;

  io::Provenance provenance = provenance_of(io::kGaFuzzyImmKind, config, training.digest());
  provenance.training_metrics["learned_part_on"] = 0.0;
  provenance.training_metrics["classical_baseline"] = 1.0;
  provenance.training_metrics[training.plots_only ? "excess_nll" : "zeta_p_plus_zeta_v"] =
      baseline.score;
  if (training.plots_only) provenance.training_metrics["trained_without_truth"] = 1.0;
  write_model_file(out, provenance, [&](io::ModelFileWriter& writer) {
    io::write_ga_fuzzy_imm(writer, tuned_baseline_spec(config));
  });

  TunedBaselineResult result{
      baseline, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
      training.criterion()};
  nlohmann::json metrics = metrics_of(io::kGaFuzzyImmKind, out, config.name);
  metrics["classical_baseline"] =
      "the constant-q IMM tuned on the training split (one constant rule per level, no learned "
      "part)";
  metrics["regime"] = config.regime.name;
  metrics["baseline"] = {{"process_noise", baseline.process_noise},
                         {"transition_stay", baseline.transition_stay},
                         {"training_criterion", training.criterion()},
                         {"training_zeta_p_plus_zeta_v", baseline.score},
                         {"evaluations", baseline.evaluations}};
  metrics["wall_seconds"] = result.wall_seconds;
  write_json_atomically(metrics_path(out), metrics);
  return result;
}

}  // namespace imm::trainer::ga
