// SPDX-License-Identifier: Apache-2.0
// Training speed (Google Benchmark): one back-propagation epoch of the input estimator's 2-10-10-1
// network on the default training features (per-sample, the seed's classic update), one FCM-fit
// objective evaluation, a whole TSK sensor fit, and the GA's IMM fitness of one genome.
//   build/bin/imm-train-bench --benchmark_min_time=1

#include <benchmark/benchmark.h>

#include "bench_main.hpp"
#include "imm/datasets/random.hpp"
#include "imm/datasets/track.hpp"
#include "imm/trainer/fcm/fcm_trainer.hpp"
#include "imm/trainer/ga/ga_config.hpp"
#include "imm/trainer/ga/imm_fitness_batch.hpp"
#include "imm/trainer/mlp/mlp_trainer.hpp"
#include "imm/trainer/mlp/network_training.hpp"
#include "imm/trainer/tsk/tsk_trainer.hpp"
#include "workloads.hpp"

namespace {

std::filesystem::path preset(const char* name) {
  return std::filesystem::path(IMM_SOURCE_DIR "/configs/regimes/paper") /
         (std::string(name) + ".toml");
}

void BM_BackpropagationEpoch(benchmark::State& state) {
  const auto config = imm::trainer::mlp::load_mlp_config(
      IMM_SOURCE_DIR "/configs/mlp_input_estimator.toml", preset("input_estimator_training"));
  const auto features = imm::trainer::mlp::make_features(
      config, imm::datasets::draw_split(config.regime, imm::datasets::Split::kTraining, 0));
  imm::trainer::mlp::Samples samples = features.samples;
  // Standardize as the trainer does.
  const Eigen::RowVector2d mean = samples.inputs.colwise().mean();
  const Eigen::RowVector2d scale =
      (samples.inputs.rowwise() - mean).cwiseAbs2().colwise().mean().cwiseSqrt();
  for (Eigen::Index i = 0; i < samples.inputs.rows(); ++i) {
    samples.inputs.row(i) = (samples.inputs.row(i) - mean).cwiseQuotient(scale);
  }
  imm::trainer::mlp::Network network({2, 10, 10, 1}, imm::Activation::kSigmoid, 12.0, 0.5, 1);
  std::vector<double> rows(static_cast<std::size_t>(samples.inputs.size()));
  for (Eigen::Index i = 0; i < samples.inputs.rows(); ++i) {
    rows[static_cast<std::size_t>(2 * i)] = samples.inputs(i, 0);
    rows[static_cast<std::size_t>(2 * i + 1)] = samples.inputs(i, 1);
  }
  for (auto _ : state) {
    // One epoch: every sample once, in order (train() adds a shuffle).
    for (Eigen::Index i = 0; i < samples.inputs.rows(); ++i) {
      network.update_on_sample(rows.data() + 2 * i, samples.targets(i), 0.1, 0.1);
    }
    benchmark::ClobberMemory();
  }
  state.counters["samples"] = static_cast<double>(samples.inputs.rows());
}
BENCHMARK(BM_BackpropagationEpoch);

// One objective evaluation of the FCM fit: the shipped fit's FCM-IMM over the training
// split of configs/regimes/paper/fcm_imm_training.toml (16 × 300 scans, both axes), at the default
// thread count.
void BM_FcmObjectiveEvaluation(benchmark::State& state) {
  const auto config = imm::trainer::fcm::load_fcm_config(IMM_SOURCE_DIR "/configs/fcm_imm.toml",
                                                         preset("fcm_imm_training"));
  const auto data = imm::datasets::draw_split(config.regime, imm::datasets::Split::kTraining, 0);
  auto spec = config.filter;
  spec.compensation_gain = 0.06;
  spec.clustering.fuzzifier = 4.0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(imm::trainer::fcm::score_filter(
        [&] { return imm::make_fcm_imm_filter(spec); }, data, config.filter.measurement_sigma));
  }
  state.counters["trajectories"] = static_cast<double>(data.tracks.size());
}
BENCHMARK(BM_FcmObjectiveEvaluation)->Unit(benchmark::kMillisecond);

// The whole TSK fit of one config (both outputs: FCRM with its restarts, premises, Levenberg–
// Marquardt fine tuning, σ) on its 8000 samples, without the file writing; range(0) = 1 for the
// hard sensor. At the default thread count (the restarts run in parallel).
void BM_TskFit(benchmark::State& state) {
  namespace tsk = imm::trainer::tsk;
  const auto config = tsk::load_tsk_config(
      state.range(0) == 1 ? IMM_SOURCE_DIR "/configs/tsk_range_sensor_hard.toml"
                          : IMM_SOURCE_DIR "/configs/tsk_range_sensor.toml",
      preset(state.range(0) == 1 ? "fimm_table1_hard" : "fimm_table1"));
  const auto data = tsk::calibration_samples(config).data;
  const auto parts = tsk::split(data, config.validation_fraction, config.seed);
  for (auto _ : state) {
    for (int i = 0; i < 2; ++i) {
      const Eigen::VectorXd z = parts.training_outputs.col(i);
      const auto clusters = tsk::fcrm(parts.training_inputs, z, config.fcrm,
                                      imm::datasets::derive_seed(config.seed, 100 + i));
      auto rules = tsk::rules_from_clusters(parts.training_inputs, clusters, config.fcrm.fuzzifier);
      benchmark::DoNotOptimize(
          tsk::fine_tune(rules, config.t_norm, parts.training_inputs, z, config.fine_tuning));
    }
  }
  state.counters["samples"] = static_cast<double>(parts.training_inputs.rows());
  state.SetLabel(state.range(0) == 1 ? "hard sensor" : "default sensor");
}
BENCHMARK(BM_TskFit)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// --- The reference workloads (tools/workloads)
// ------------------------------------------------------

// W2a: 6000 full-batch epochs of the 2-10-10-1 network from the given weights; the final MSE is
// deterministic and checked against the README figure.
void BM_W2a_FullBatch(benchmark::State& state) {
  const auto input = imm::workloads::load_w2(imm::workloads::input_folder());
  double mse = 0.0;
  for (auto _ : state) mse = imm::workloads::run_w2a(input, 6000);
  if (std::abs(mse - imm::workloads::kW2aFinalMse) > 1e-9) {
    state.SkipWithError("W2a: final MSE differs from the README figure by more than 1e-9");
  }
  state.counters["final_mse"] = mse;
}
BENCHMARK(BM_W2a_FullBatch)->Unit(benchmark::kMillisecond)->MinTime(2.0);

// W2b: 100 epochs of one-sample steps in fixed order.
void BM_W2b_PerSample(benchmark::State& state) {
  const auto input = imm::workloads::load_w2(imm::workloads::input_folder());
  double mse = 0.0;
  for (auto _ : state) mse = imm::workloads::run_w2b(input, 100);
  if (std::abs(mse - imm::workloads::kW2bFinalMse) > 1e-9) {
    state.SkipWithError("W2b: final MSE differs from the README figure by more than 1e-9");
  }
  state.counters["final_mse"] = mse;
}
BENCHMARK(BM_W2b_PerSample)->Unit(benchmark::kMillisecond)->MinTime(1.0);

// W4: one generation of the GA engine (selection, crossover, mutation, evaluation) on the
// sum-of-squares toy, population 500 × 250 genes, one thread.
void BM_W4_GaGeneration(benchmark::State& state) {
  const imm::workloads::SumOfSquares problem;
  const imm::trainer::ga::GeneticAlgorithm ga(problem, imm::workloads::w4_options(), 7);
  imm::trainer::ga::Population population = ga.initialize();
  const double initial = population.evaluations[population.best_index()].fitness;
  for (auto _ : state) ga.evolve(population);
  const double best = population.evaluations[population.best_index()].fitness;
  if (!(best > initial)) state.SkipWithError("W4: the best fitness did not improve");
  state.counters["best_sum_of_squares"] = -best;
  state.counters["generation"] = population.generation;
}
BENCHMARK(BM_W4_GaGeneration)->Unit(benchmark::kMicrosecond);

// The GA's IMM fitness of one genome on the paper's training split (18 one-axis trajectories of
// 160 scans): the lane batch against the runtime filter one trajectory at a time, with
// state.range(0) rules in each of the three levels' tables.
void ga_fitness(benchmark::State& state, bool batched) {
  using namespace imm::trainer::ga;
  using imm::trainer::make_training_set;
  using imm::trainer::TrainingSet;
  const GaTrainingConfig config =
      load_ga_config(IMM_SOURCE_DIR "/configs/ga_fuzzy_imm.toml", preset("ga_imm_training"));
  const TrainingSet set = make_training_set(config.regime, imm::datasets::Split::kTraining);
  imm::datasets::Rng rng(3);
  imm::GaFuzzyImmSpec spec;
  spec.settings = config.filter;
  for (int level = 0; level < 3; ++level) {
    std::vector<imm::FuzzyRule> rules;
    for (int r = 0; r < state.range(0); ++r) {
      rules.push_back({rng.uniform(-1.0, 1.0), rng.uniform(0.1, 2.0), rng.uniform(-1.0, 1.0),
                       rng.uniform(0.1, 2.0), std::pow(10.0, rng.uniform(-6.0, -2.0))});
    }
    spec.levels.push_back(
        {std::string("level ").append(std::to_string(level)), 0.01, imm::FuzzyRuleTable(rules)});
  }
  ProblemOptions options;
  const ImmFitnessBatch batch(set);
  for (auto _ : state) {
    if (batched) {
      ImmRunErrors run = batch.run(spec);
      benchmark::DoNotOptimize(run);
    } else {
      Evaluation e = evaluate_imm(spec, set, options, 1);
      benchmark::DoNotOptimize(e);
    }
  }
  // The figure both compute (eq. 17's mean position error), once outside the timing.
  const ImmRunErrors run = batch.run(spec);
  state.counters["position_error"] = batched ? run.position_abs_sum / static_cast<double>(run.count)
                                             : evaluate_imm(spec, set, options, 1).position_error;
  state.counters["lane_steps_per_s"] = benchmark::Counter(
      static_cast<double>(set.total_steps()), benchmark::Counter::kIsIterationInvariantRate);
}
void BM_GaFitnessBatched(benchmark::State& state) { ga_fitness(state, true); }
void BM_GaFitnessRuntimeFilter(benchmark::State& state) { ga_fitness(state, false); }
BENCHMARK(BM_GaFitnessBatched)->Arg(1)->Arg(5)->Arg(25)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_GaFitnessRuntimeFilter)->Arg(1)->Arg(5)->Arg(25)->Unit(benchmark::kMicrosecond);

}  // namespace

int main(int argc, char** argv) { return imm::bench::main_with_lane_isa(argc, argv); }
