#include "imm/evaluation/ga_imm_experiment.hpp"

#include <algorithm>
#include <sstream>

#include "imm/evaluation/baseline_tuning.hpp"
#include "imm/filters/fuzzy_noise_filter.hpp"
#include "imm/io/ga_fuzzy_imm_file.hpp"
#include "imm/trainer/ga/ga_config.hpp"

namespace imm::evaluation {
namespace {

double percentile(std::vector<double>& values, double p) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto k = static_cast<std::size_t>(p * static_cast<double>(values.size() - 1) + 0.5);
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

std::string list(const std::vector<double>& values) {
  std::ostringstream out;
  for (std::size_t i = 0; i < values.size(); ++i) out << (i ? ", " : "") << values[i];
  return out.str();
}

}  // namespace

const std::map<std::string, std::pair<double, double>>& seed000_table3() {
  static const std::map<std::string, std::pair<double, double>> table = {
      {"AIMM3", {0.6089, 0.1235}}, {"AIMM5", {0.6003, 0.1176}}, {"GA-IMM", {0.5138, 0.0845}}};
  return table;
}

GaImmExperimentResult run_ga_imm_experiment(const GaImmExperimentOptions& options) {
  const trainer::ga::GaTrainingConfig config = trainer::ga::load_ga_config(options.training_config);
  const GaFuzzyImmSpec learned = io::read_ga_fuzzy_imm(options.model);
  const GaFuzzyImmSpec paper = io::read_ga_fuzzy_imm(options.paper_model);

  datasets::ManeuverScenario scenario = datasets::seed000_scenario();
  scenario.runs = options.runs;
  scenario.seed = options.seed;
  if (std::abs(config.filter.sample_period - scenario.sample_period) > 1e-12 ||
      std::abs(config.filter.measurement_sigma - scenario.measurement.sigma(0)) > 1e-12) {
    throw std::runtime_error(
        options.training_config.string() +
        ": [filter] does not match the seed-000 scenario (T = 1 s, σ = 0.5 km)");
  }
  const datasets::ScenarioData data = datasets::simulate(scenario);

  GaImmExperimentResult result;
  result.runs = scenario.runs;
  result.steps = scenario.steps;
  result.seed = scenario.seed;
  result.dataset_digest = datasets::digest(data);

  // Tuning on the training trajectories of every level.
  std::vector<trainer::ga::TrainingSet> training;
  for (std::size_t level = 0; level < config.training.levels.size(); ++level) {
    training.push_back(trainer::ga::make_training_set(config.training_set_options(level, false)));
  }
  AimmSpec aimm3;
  aimm3.settings = config.filter;
  aimm3.process_noise_sigma = config.training.process_noise_sigma;
  aimm3.intervals = {0.04};
  AimmSpec aimm5 = aimm3;
  aimm5.intervals = {0.02, 0.04};
  const Tuned<AimmSpec> aimm_tuned = tune_aimm(aimm3, training, 2);
  AxisCvImmSpec imm_base;
  imm_base.settings = config.filter;
  const Tuned<AxisCvImmSpec> imm_tuned = tune_axis_cv_imm(imm_base, training, 3);
  result.tuned["AIMM-tuned"] = "intervals [" + list(aimm_tuned.spec.intervals) + "] km/s² (" +
                               std::to_string(aimm_tuned.evaluations) + " evaluations)";
  result.tuned["IMM-tuned"] = "q [" + list(imm_tuned.spec.process_noise) + "] (km/s²)² (" +
                              std::to_string(imm_tuned.evaluations) + " evaluations)";
  auto fuzzy_axis = [](const GaFuzzyImmSpec& spec) -> AxisFilterFactory {
    return [&spec] { return std::make_unique<ImmAxisFilter>(build_ga_fuzzy_axis_imm(spec)); };
  };
  result.training_scores["AIMM3"] =
      axis_score([&] { return std::make_unique<AimmAxisFilter>(aimm3); }, training);
  result.training_scores["AIMM5"] =
      axis_score([&] { return std::make_unique<AimmAxisFilter>(aimm5); }, training);
  result.training_scores["AIMM-tuned"] = aimm_tuned.score;
  result.training_scores["IMM-tuned"] = imm_tuned.score;
  result.training_scores["GA-IMM-paper"] = axis_score(fuzzy_axis(paper), training);
  result.training_scores["GA-IMM"] = axis_score(fuzzy_axis(learned), training);

  const TrackOptions track = axis_track_options(config.filter);
  result.filters.push_back(run_monte_carlo(
      "AIMM3", [&] { return make_aimm_filter(aimm3); }, track, scenario, data));
  result.filters.push_back(run_monte_carlo(
      "AIMM5", [&] { return make_aimm_filter(aimm5); }, track, scenario, data));
  result.filters.push_back(run_monte_carlo(
      "AIMM-tuned", [&] { return make_aimm_filter(aimm_tuned.spec); }, track, scenario, data));
  result.filters.push_back(run_monte_carlo(
      "IMM-tuned", [&] { return make_axis_cv_imm_filter(imm_tuned.spec); }, track, scenario, data));

  for (const auto& [name, spec] :
       {std::pair<std::string, const GaFuzzyImmSpec*>{"GA-IMM-paper", &paper},
        std::pair<std::string, const GaFuzzyImmSpec*>{"GA-IMM", &learned}}) {
    std::vector<std::vector<double>> q(spec->levels.size());
    const StepObserver observe_q = [&](std::size_t, int, const TrackFilter& filter) {
      const auto& two_axis = static_cast<const TwoAxisFilter&>(filter);
      for (int axis = 0; axis < 2; ++axis) {
        const auto& imm = static_cast<const ImmAxisFilter&>(two_axis.axis(axis)).imm();
        for (int j = 0; j < imm.mode_count(); ++j) {
          q[static_cast<std::size_t>(j)].push_back(
              static_cast<const FuzzyNoiseMode&>(imm.mode(j)).process_noise());
        }
      }
    };
    const GaFuzzyImmSpec* captured = spec;
    result.filters.push_back(run_monte_carlo(
        name, [captured] { return make_ga_fuzzy_imm_filter(*captured); }, track, scenario, data,
        observe_q));
    for (std::size_t j = 0; j < q.size(); ++j) {
      result.spreads.push_back({name, spec->levels[j].name, percentile(q[j], 0.01),
                                percentile(q[j], 0.50), percentile(q[j], 0.99)});
    }
  }
  return result;
}

}  // namespace imm::evaluation
