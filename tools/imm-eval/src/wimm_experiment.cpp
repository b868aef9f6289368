#include "imm/evaluation/wimm_experiment.hpp"

#include <sstream>

#include "imm/datasets/random.hpp"
#include "imm/io/wimm_file.hpp"
#include "imm/trainer/wimm/wimm_trainer.hpp"

namespace imm::evaluation {

WimmExperimentResult run_wimm_experiment(const WimmExperimentOptions& options) {
  const trainer::wimm::WimmTrainingConfig config =
      trainer::wimm::load_wimm_config(options.training_config);
  const WimmSpec trained = io::read_wimm(options.model);

  WimmSpec normal = config.filter;
  normal.fusion = FusionVariant::kNone;
  WimmSpec seed_fusion = config.filter;
  seed_fusion.fusion = FusionVariant::kSeed;
  seed_fusion.threshold = 0.7;
  seed_fusion.alpha = 0.5;
  WimmSpec correlated = seed_fusion;
  correlated.fusion = FusionVariant::kCorrelated;
  correlated.update = MeasurementUpdate::kExtended;  // the derivation is for the polar update
  const trainer::wimm::Tuned tuned_normal =
      trainer::wimm::tune_normal_imm(config, trainer::wimm::make_training_scenarios(config));

  WimmExperimentResult result;
  result.runs = options.runs;
  result.seed = options.seed;
  std::ostringstream text;
  text << "threshold " << trained.threshold << ", alpha " << trained.alpha << " ("
       << to_string(trained.fusion) << " fusion, " << to_string(trained.update) << " update)";
  result.parameters["wIMM"] = text.str();
  text.str("");
  text << "q1 " << tuned_normal.spec.cv_process_noise << " (m/s²)², P(CV→CV) "
       << tuned_normal.spec.transition(0, 0) << " (" << tuned_normal.evaluations << " evaluations)";
  result.parameters["nIMM-tuned"] = text.str();

  for (int number : {1, 2}) {
    datasets::ManeuverScenario scenario = datasets::seed004_scenario(number);
    scenario.runs = options.runs;
    scenario.seed = datasets::derive_seed(options.seed, static_cast<std::uint64_t>(number));
    const datasets::ScenarioData data = datasets::simulate(scenario);
    WimmScenarioResult s;
    s.number = number;
    for (const auto& [name, spec] :
         std::vector<std::pair<std::string, WimmSpec>>{{"nIMM", normal},
                                                       {"wIMM", trained},
                                                       {"wIMM-seed", seed_fusion},
                                                       {"wIMM-correlated", correlated},
                                                       {"nIMM-tuned", tuned_normal.spec}}) {
      s.rows.push_back({name, trainer::wimm::score_tracking(spec, scenario, data)});
    }
    result.scenarios.push_back(std::move(s));
  }
  return result;
}

}  // namespace imm::evaluation
