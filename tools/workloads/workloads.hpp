// SPDX-License-Identifier: Apache-2.0
#pragma once
/// The four reference workloads (docs/performance.md; inputs in tools/workloads/inputs): their
/// inputs, and each run through our own code with the figure that checks it. The benchmarks
/// (imm-bench, imm-train-bench) time these functions; tests/tools/workloads_test.cpp checks their
/// results against independent references at small sizes.
///
///   W1  the plain IMM of configs/track/cv3_imm.toml (= the workload's filter) on 10 000 plots
///   W2a full-batch back-propagation of a 2-10-10-1 network, 6000 epochs, from given weights
///   W2b the same network, one sample per step in fixed order, 100 epochs
///   W3  fuzzy c-means of 4000 scalars from given memberships (c = 3, m = 2, tolerance 1e-6)
///   W4  the GA engine on the sum-of-squares toy (population 500, 250 genes, 100 generations)

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <vector>

#include "imm/estimation/gaussian_state.hpp"
#include "imm/filters/plain_imm.hpp"
#include "imm/models/learned/fuzzy_c_means.hpp"
#include "imm/models/learned/mlp.hpp"
#include "imm/trainer/ga/genetic_algorithm.hpp"
#include "imm/trainer/mlp/network_training.hpp"

namespace imm::workloads {

/// The results the benchmarks check (README, "Performance"): W2a's and W2b's final MSE and W3's
/// objective are deterministic.
inline constexpr double kW2aFinalMse = 0.024814674860501568;
inline constexpr double kW2bFinalMse = 0.0008177353835101853;
inline constexpr double kW3Objective = 3241.7278918502684;

/// The folder of the workloads' input files: $IMM_BENCH_INPUTS, else tools/workloads/inputs (the
/// reference workloads' own files, copied unchanged). Throws std::runtime_error naming the folder
/// when w1_measurements.csv is missing.
[[nodiscard]] std::filesystem::path input_folder();

/// A CSV of numbers with a header line: the columns after the first (an index), row by row.
/// Strict: every field must be a whole number text (std::from_chars), every row as wide as the
/// header; errors name the file and line.
[[nodiscard]] Eigen::MatrixXd read_table(const std::filesystem::path& path);

// --- W1 ---------------------------------------------------------------------------------------

struct W1Input {
  Eigen::MatrixXd plots;  ///< n × 2: zx, zy
  Eigen::MatrixXd truth;  ///< n × 4: x, vx, y, vy
};
[[nodiscard]] W1Input load_w1(const std::filesystem::path& folder);
/// configs/track/cv3_imm.toml, which is the workload's filter.
[[nodiscard]] PlainImmSpec w1_spec();
/// x = [15.84, 0.0106, 15.84, 0.0106], P = diag(1, 0.01, 1, 0.01).
[[nodiscard]] GaussianState<4> w1_start();

struct W1Result {
  GaussianState<4> final_estimate;
  double position_rmse = 0.0;  ///< over all scans, against the truth columns
};
/// The plain IMM (ImmEstimator from build_plain_imm) over the first `scans` plots.
[[nodiscard]] W1Result run_w1(const W1Input& input, int scans);

// --- W2 ---------------------------------------------------------------------------------------

struct W2Input {
  trainer::mlp::Samples samples;  ///< 1000 × 2 inputs, targets
  Mlp initial;                    ///< 2-10-10-1, sigmoid hidden, linear output, scale 1
};
[[nodiscard]] W2Input load_w2(const std::filesystem::path& folder);

/// Plain gradient descent with learning rate 0.1 on the MSE mean (y − t)², full batch, `epochs`
/// epochs; returns the trained network's MSE on the samples. (Our loss is ½ MSE: rate 0.2 on it
/// is the same update to the bit, 0.2 g = 0.1 (2 g) exactly in binary.)
[[nodiscard]] double run_w2a(const W2Input& input, int epochs,
                             trainer::mlp::Network* out = nullptr);
/// One sample per step, order 0 … n − 1, `epochs` epochs, rate 0.1 on (y − t)².
[[nodiscard]] double run_w2b(const W2Input& input, int epochs,
                             trainer::mlp::Network* out = nullptr);

// --- W3 ---------------------------------------------------------------------------------------

struct W3Input {
  std::vector<double> points;       ///< 1-D
  std::vector<double> memberships;  ///< initial, row k: the 3 memberships of point k
};
[[nodiscard]] W3Input load_w3_1d(const std::filesystem::path& folder);

struct W3Result {
  ClusterVector centers = ClusterVector::Zero();
  int iterations = 0;
  double objective = 0.0;  ///< J = Σ_k Σ_i u_ik^m (x_k − v_i)² at the final U and V
  bool converged = false;
};
/// The runtime's FCM (imm/models/learned/fuzzy_c_means.hpp) from the given memberships, c = 3, m =
/// 2, stop when max |ΔU| < 1e-6. `memberships` is scratch of 3 n values.
[[nodiscard]] W3Result run_w3(const W3Input& input, std::vector<double>& memberships);

// --- W4 ---------------------------------------------------------------------------------------

/// Sum of squares of 250 real genes in [−5, 5], minimized (fitness = −Σ x²), as a GenomeProblem
/// of 50 slots of 5 genes; the slots' activity bits do not enter the fitness.
class SumOfSquares final : public trainer::ga::GenomeProblem {
 public:
  explicit SumOfSquares(int genes = 250);
  [[nodiscard]] int max_rules() const override { return slots_; }
  [[nodiscard]] const std::vector<double>& lower() const override { return lower_; }
  [[nodiscard]] const std::vector<double>& upper() const override { return upper_; }
  [[nodiscard]] trainer::ga::Evaluation evaluate(const trainer::ga::Genome& genome) const override;

 private:
  int slots_;
  std::vector<double> lower_, upper_;
};

/// The workload's GA settings: tournament 3, crossover 0.9, per-gene mutation 0.01, no elitism
/// (DEAP's eaSimple has none).
[[nodiscard]] trainer::ga::GaOptions w4_options(int population = 500, int generations = 100);

}  // namespace imm::workloads
