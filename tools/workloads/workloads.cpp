// SPDX-License-Identifier: Apache-2.0
#include "workloads.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string>

#include "imm/support/csv.hpp"
#include "imm/support/plain_imm_config.hpp"

namespace imm::workloads {
std::filesystem::path input_folder() {
  const char* configured = std::getenv("IMM_BENCH_INPUTS");
  std::filesystem::path folder = configured != nullptr ? std::filesystem::path(configured)
                                                       : std::filesystem::path(IMM_SOURCE_DIR) /
                                                             "tools" / "workloads" / "inputs";
  if (!std::filesystem::exists(folder / "w1_measurements.csv")) {
    throw std::runtime_error("no workload inputs in " + folder.string() +
                             " (set IMM_BENCH_INPUTS to the folder of w1_measurements.csv)");
  }
  return folder;
}

Eigen::MatrixXd read_table(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path.string());
  support::CsvReader reader(in, path.string());
  support::CsvLine line;
  if (!reader.next(line)) throw std::runtime_error(path.string() + ": empty, expected a header");
  const std::vector<std::string> header(line.fields.begin(), line.fields.end());
  const std::size_t columns = header.size();
  if (columns < 2) reader.fail("expected an index column and at least one value column");
  std::vector<double> values;
  std::size_t rows = 0;
  while (reader.next(line)) {
    if (line.fields.size() != columns) {
      reader.fail(std::to_string(line.fields.size()) + " fields, header has " +
                  std::to_string(columns));
    }
    for (std::size_t c = 1; c < columns; ++c) values.push_back(reader.real(line, c, header[c]));
    ++rows;
  }
  Eigen::MatrixXd table(static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(columns - 1));
  for (Eigen::Index r = 0; r < table.rows(); ++r)
    for (Eigen::Index c = 0; c < table.cols(); ++c)
      table(r, c) = values[static_cast<std::size_t>(r * table.cols() + c)];
  return table;
}

W1Input load_w1(const std::filesystem::path& folder) {
  const Eigen::MatrixXd table = read_table(folder / "w1_measurements.csv");
  if (table.cols() != 6) throw std::runtime_error("w1_measurements.csv: expected 7 columns");
  return {table.leftCols(2), table.rightCols(4)};
}

PlainImmSpec w1_spec() {
  return support::load_plain_imm_config(IMM_SOURCE_DIR "/configs/track/cv3_imm.toml");
}

GaussianState<4> w1_start() {
  GaussianState<4> start;
  start.mean << 15.84, 0.0106, 15.84, 0.0106;
  start.covariance = Eigen::Vector4d(1.0, 0.01, 1.0, 0.01).asDiagonal();
  return start;
}

W1Result run_w1(const W1Input& input, int scans) {
  auto imm = build_plain_imm<4>(w1_spec());
  imm.initialize(w1_start());
  double squared = 0.0;
  for (int k = 0; k < scans; ++k) {
    if (imm.step(input.plots.row(k).transpose()) != StepStatus::kOk) {
      throw std::runtime_error("W1: step " + std::to_string(k) + " failed");
    }
    const auto& x = imm.estimate().mean;
    squared += std::pow(x(0) - input.truth(k, 0), 2) + std::pow(x(2) - input.truth(k, 2), 2);
  }
  return {imm.estimate(), std::sqrt(squared / std::max(1, scans))};
}

W2Input load_w2(const std::filesystem::path& folder) {
  W2Input input;
  const Eigen::MatrixXd table = read_table(folder / "w2_samples.csv");
  if (table.cols() != 3) throw std::runtime_error("w2_samples.csv: expected 4 columns");
  input.samples.inputs = table.leftCols(2);
  input.samples.targets = table.col(2);
  std::ifstream in(folder / "w2_init_weights.json");
  if (!in) throw std::runtime_error("cannot open w2_init_weights.json");
  const nlohmann::json json = nlohmann::json::parse(in);
  std::vector<MlpLayer> layers;
  for (const char* name : {"0", "2", "4"}) {
    const auto& w = json.at(std::string(name) + ".weight");
    const auto& b = json.at(std::string(name) + ".bias");
    MlpLayer layer;
    layer.weights.resize(static_cast<Eigen::Index>(w.size()),
                         static_cast<Eigen::Index>(w.at(0).size()));
    layer.bias.resize(static_cast<Eigen::Index>(b.size()));
    for (Eigen::Index r = 0; r < layer.weights.rows(); ++r) {
      for (Eigen::Index c = 0; c < layer.weights.cols(); ++c)
        layer.weights(r, c) = w.at(static_cast<std::size_t>(r)).at(static_cast<std::size_t>(c));
      layer.bias(r) = b.at(static_cast<std::size_t>(r));
    }
    layer.activation = std::string(name) == "4" ? Activation::kLinear : Activation::kSigmoid;
    layers.push_back(std::move(layer));
  }
  input.initial = Mlp(std::move(layers), 1.0);
  return input;
}

double run_w2a(const W2Input& input, int epochs, trainer::mlp::Network* out) {
  trainer::mlp::Network network(input.initial);
  trainer::mlp::TrainingOptions options;
  options.phases = {{epochs, 0.2, 0.2}};
  options.mode = trainer::mlp::UpdateMode::kBatch;
  options.loss_every = epochs + 1;  // no loss curve inside the timed loop
  trainer::mlp::Samples none;
  none.inputs.resize(0, 2);
  (void)trainer::mlp::train(network, input.samples, none, options);
  const double mse = network.mse(input.samples);
  if (out != nullptr) *out = network;
  return mse;
}

double run_w2b(const W2Input& input, int epochs, trainer::mlp::Network* out) {
  trainer::mlp::Network network(input.initial);
  const Eigen::Index n = input.samples.inputs.rows();
  std::vector<double> rows(static_cast<std::size_t>(2 * n));
  for (Eigen::Index i = 0; i < n; ++i) {
    rows[static_cast<std::size_t>(2 * i)] = input.samples.inputs(i, 0);
    rows[static_cast<std::size_t>(2 * i + 1)] = input.samples.inputs(i, 1);
  }
  for (int e = 0; e < epochs; ++e) {
    for (Eigen::Index i = 0; i < n; ++i)
      network.update_on_sample(rows.data() + 2 * i, input.samples.targets(i), 0.2, 0.2);
  }
  const double mse = network.mse(input.samples);
  if (out != nullptr) *out = network;
  return mse;
}

W3Input load_w3_1d(const std::filesystem::path& folder) {
  W3Input input;
  const Eigen::MatrixXd points = read_table(folder / "w3_points_1d.csv");
  const Eigen::MatrixXd u0 = read_table(folder / "w3_u0_1d.csv");
  if (points.cols() != 1 || u0.cols() != 3 || u0.rows() != points.rows()) {
    throw std::runtime_error("w3 1-D inputs: expected n × 1 points and n × 3 memberships");
  }
  input.points.assign(points.data(), points.data() + points.size());
  for (Eigen::Index k = 0; k < u0.rows(); ++k)
    for (int i = 0; i < 3; ++i) input.memberships.push_back(u0(k, i));
  return input;
}

W3Result run_w3(const W3Input& input, std::vector<double>& memberships) {
  memberships = input.memberships;
  FuzzyCMeansSettings settings;
  settings.fuzzifier = 2.0;
  settings.tolerance = 1e-6;
  settings.max_iterations = 1000;
  const FcmResult result = fuzzy_c_means_from_memberships(input.points, memberships, settings);
  W3Result out;
  out.centers = result.centers;
  out.iterations = result.iterations;
  out.converged = result.converged;
  out.objective = fcm_objective(input.points, result.centers, memberships, settings.fuzzifier);
  return out;
}

SumOfSquares::SumOfSquares(int genes)
    : slots_(genes / trainer::ga::kGenesPerRule),
      lower_(static_cast<std::size_t>(genes), -5.0),
      upper_(static_cast<std::size_t>(genes), 5.0) {
  if (genes < trainer::ga::kGenesPerRule || genes % trainer::ga::kGenesPerRule != 0) {
    throw std::invalid_argument("SumOfSquares: genes must be a positive multiple of 5");
  }
}

trainer::ga::Evaluation SumOfSquares::evaluate(const trainer::ga::Genome& genome) const {
  // Σ x² in eight partial sums (gene g into sum g mod 8) added pairwise at the end, as numpy's
  // sum does: vector additions instead of one chain of 250 dependent ones.
  constexpr std::size_t kLanes = 8;
  const std::vector<double>& x = genome.genes;
  double lanes[kLanes] = {};
  std::size_t g = 0;
  for (; g + kLanes <= x.size(); g += kLanes) {
    for (std::size_t l = 0; l < kLanes; ++l) lanes[l] += x[g + l] * x[g + l];
  }
  for (std::size_t l = 0; g + l < x.size(); ++l) lanes[l] += x[g + l] * x[g + l];
  const double sum = ((lanes[0] + lanes[1]) + (lanes[2] + lanes[3])) +
                     ((lanes[4] + lanes[5]) + (lanes[6] + lanes[7]));
  trainer::ga::Evaluation evaluation;
  evaluation.fitness = -sum;
  evaluation.error = sum;
  evaluation.rules = genome.rule_count();
  return evaluation;
}

trainer::ga::GaOptions w4_options(int population, int generations) {
  trainer::ga::GaOptions options;
  options.population = population;
  options.generations = generations;
  options.tournament_size = 3;
  options.crossover_rate = 0.9;
  options.mutation_rate = 0.01;
  options.elite = 0;
  return options;
}

}  // namespace imm::workloads
