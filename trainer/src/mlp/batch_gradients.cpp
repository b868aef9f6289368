// SPDX-License-Identifier: Apache-2.0
#include "batch_gradients.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "exp_nonpositive.hpp"
#include "imm/math/lane_math.hpp"

namespace imm::trainer::mlp {
namespace {

constexpr int kLanes = 8;  // one AVX-512 or two AVX2 vectors of samples

// The multiply-adds are fused (std::fma: one rounding, the same bits on every machine); the
// clones are the instruction sets that fuse them in hardware (x86-64-v3 is AVX2 with FMA), and
// the default clone computes the same fused results in software.
#if IMM_HAS_VECTOR_CLONES
#define IMM_FMA_CLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define IMM_FMA_CLONES
#endif

// Every lane's running share of the gradient (layouts as the layers': column-major weights).
template <int I, int H1, int H2>
struct LaneSums {
  static constexpr int W = kLanes;
  static constexpr auto kW1 = static_cast<std::size_t>(H1) * I;
  static constexpr auto kW2 = static_cast<std::size_t>(H2) * H1;
  std::array<std::array<double, W>, kW1> w1{};
  std::array<std::array<double, W>, H1> b1{};
  std::array<std::array<double, W>, kW2> w2{};
  std::array<std::array<double, W>, H2> b2{};
  std::array<std::array<double, W>, H2> w3{};
  std::array<std::array<double, W>, 1> b3{};
};

// σ(s) = 1/(1 + e⁻ˢ) of a layer's H pre-activations in place, as n/d with d = 1 + e^−|s| in
// [1, 2] and n = 1 (s ≥ 0) or e^−|s|: two rows share one division (1/d₁ = d₂/(d₁d₂)), which the
// bounded d keeps from overflowing. Within 3 ulp of the quotient; the divisions were the block's
// bottleneck.
template <int H>
[[gnu::always_inline]] inline void sigmoids(double (&a)[H][kLanes]) {
  constexpr int W = kLanes;
  for (int r = 0; r + 1 < H; r += 2) {
    IMM_LANES {
      const double s0 = a[r][l], s1 = a[r + 1][l];
      const double t0 = exp_nonpositive(-std::abs(s0)), t1 = exp_nonpositive(-std::abs(s1));
      const double d0 = 1.0 + t0, d1 = 1.0 + t1;
      const double q = 1.0 / (d0 * d1);
      a[r][l] = pick(s0 >= 0.0, 1.0, t0) * (d1 * q);
      a[r + 1][l] = pick(s1 >= 0.0, 1.0, t1) * (d0 * q);
    }
  }
  if constexpr (H % 2 == 1) {
    IMM_LANES {
      const double s = a[H - 1][l], t = exp_nonpositive(-std::abs(s));
      a[H - 1][l] = pick(s >= 0.0, 1.0, t) / (1.0 + t);
    }
  }
}

// A sigmoid layer of R units over C inputs for every lane: out = σ(b + W in), W column-major,
// each unit's sum from its bias input by input.
template <int R, int C>
[[gnu::always_inline]] inline void sigmoid_layer(const double* w, const double* b,
                                                 const double (&in)[C][kLanes],
                                                 double (&out)[R][kLanes]) {
  constexpr int W = kLanes;
  for (int r = 0; r < R; ++r) {
    IMM_LANES {
      double s = b[r];
      for (int c = 0; c < C; ++c) s = std::fma(w[c * R + r], in[c][l], s);
      out[r][l] = s;
    }
  }
  sigmoids<R>(out);
}

// One block of kLanes samples from `first` (`valid` of them real; the rest weigh nothing).
// kSigmoidOutput: the output unit's activation (otherwise linear), a template argument so that a
// linear output computes no exponential.
template <int I, int H1, int H2, bool kSigmoidOutput>
[[gnu::always_inline]] inline void block(const std::vector<MlpLayer>& layers, double inverse_scale,
                                         const Eigen::MatrixXd& inputs,
                                         const Eigen::VectorXd& targets, Eigen::Index first,
                                         int valid, double inverse_n, LaneSums<I, H1, H2>& g) {
  constexpr int W = kLanes;
  const double* w1 = layers[0].weights.data();
  const double* w2 = layers[1].weights.data();
  const double* w3 = layers[2].weights.data();
  const double* b1 = layers[0].bias.data();
  const double* b2 = layers[1].bias.data();
  const double b3 = layers[2].bias(0);
  alignas(64) double x[I][W], t[W], weight[W];
  for (int l = 0; l < W; ++l) {
    const Eigen::Index s = first + (l < valid ? l : 0);
    for (int c = 0; c < I; ++c) x[c][l] = inputs(s, c);
    t[l] = targets(s) * inverse_scale;
    weight[l] = l < valid ? inverse_n : 0.0;
  }
  alignas(64) double a1[H1][W], a2[H2][W], d3[W], d2[H2][W];
  sigmoid_layer<H1, I>(w1, b1, x, a1);
  sigmoid_layer<H2, H1>(w2, b2, a1, a2);
  IMM_LANES {
    double s = b3;
    for (int c = 0; c < H2; ++c) s = std::fma(w3[c], a2[c][l], s);
    if constexpr (kSigmoidOutput) {
      const double a3 = 1.0 / (1.0 + lane_exp(-s));
      d3[l] = (a3 - t[l]) * (a3 * (1.0 - a3)) * weight[l];
    } else {
      d3[l] = (s - t[l]) * weight[l];
    }
    g.b3[0][l] += d3[l];
  }
  for (int c = 0; c < H2; ++c) {
    IMM_LANES {
      g.w3[c][l] = std::fma(d3[l], a2[c][l], g.w3[c][l]);
      d2[c][l] = w3[c] * d3[l] * (a2[c][l] * (1.0 - a2[c][l]));
      g.b2[c][l] += d2[c][l];
    }
  }
  for (int c = 0; c < H1; ++c) {
    IMM_LANES {
      double sum = 0.0;
      for (int r = 0; r < H2; ++r) {
        g.w2[c * H2 + r][l] = std::fma(d2[r][l], a1[c][l], g.w2[c * H2 + r][l]);
        sum = std::fma(w2[c * H2 + r], d2[r][l], sum);
      }
      const double d1 = sum * (a1[c][l] * (1.0 - a1[c][l]));
      g.b1[c][l] += d1;
      for (int i = 0; i < I; ++i) g.w1[i * H1 + c][l] = std::fma(d1, x[i][l], g.w1[i * H1 + c][l]);
    }
  }
}

// The blocks from `begin` to `end` (sample indices, `begin` a multiple of kLanes).
template <int I, int H1, int H2, bool kSigmoidOutput>
[[gnu::flatten]] IMM_FMA_CLONES void blocks(const std::vector<MlpLayer>& layers,
                                            double output_scale, const Eigen::MatrixXd& inputs,
                                            const Eigen::VectorXd& targets, Eigen::Index begin,
                                            Eigen::Index end, LaneSums<I, H1, H2>& g) {
  const double inverse_n = 1.0 / static_cast<double>(inputs.rows());
  for (Eigen::Index first = begin; first < end; first += kLanes) {
    const int valid = static_cast<int>(std::min<Eigen::Index>(kLanes, end - first));
    block<I, H1, H2, kSigmoidOutput>(layers, 1.0 / output_scale, inputs, targets, first, valid,
                                     inverse_n, g);
  }
}

// Gradient row k of a chunk's lane shares: w1, b1, w2, b2, w3, b3 in turn (kRows rows).
template <int I, int H1, int H2>
struct Rows {
  static constexpr int kW1 = H1 * I, kB1 = kW1 + H1, kW2 = kB1 + H2 * H1, kB2 = kW2 + H2,
                       kW3 = kB2 + H2, kRows = kW3 + 1;
  static const std::array<double, kLanes>& row(const LaneSums<I, H1, H2>& g, int k) {
    const auto at = [](int i) { return static_cast<std::size_t>(i); };
    if (k < kW1) return g.w1[at(k)];
    if (k < kB1) return g.b1[at(k - kW1)];
    if (k < kW2) return g.w2[at(k - kB1)];
    if (k < kB2) return g.b2[at(k - kW2)];
    if (k < kW3) return g.w3[at(k - kB2)];
    return g.b3[0];
  }
  // Where row k of the gradient goes.
  static double& out(std::vector<Eigen::MatrixXd>& weights, std::vector<Eigen::VectorXd>& biases,
                     int k) {
    if (k < kW1) return weights[0].data()[k];
    if (k < kB1) return biases[0].data()[k - kW1];
    if (k < kW2) return weights[1].data()[k - kB1];
    if (k < kB2) return biases[1].data()[k - kW2];
    if (k < kW3) return weights[2].data()[k - kB2];
    return biases[2].data()[0];
  }
};

// Row k of the chunks' lane shares: summed over the chunks in order, lane by lane, then over the
// lanes by halves (lane l + lane l + w, w = 4, 2, 1): a fixed order, so the same bits at any
// thread count.
template <int I, int H1, int H2>
double reduce_row(const std::vector<LaneSums<I, H1, H2>>& chunks, int k) {
  using R = Rows<I, H1, H2>;
  std::array<double, kLanes> acc = R::row(chunks.front(), k);
  for (std::size_t c = 1; c < chunks.size(); ++c) {
    const auto& share = R::row(chunks[c], k);
    for (std::size_t l = 0; l < acc.size(); ++l) acc[l] += share[l];
  }
  for (std::size_t w = acc.size() / 2; w >= 1; w /= 2) {
    for (std::size_t l = 0; l < w; ++l) acc[l] += acc[l + w];
  }
  return acc[0];
}

// Samples per chunk, at least: below it one chunk (and one thread) does the whole batch.
constexpr Eigen::Index kChunkSamples = 128;
// Chunks of a large batch: a fixed number, so that the sums do not depend on the thread count.
constexpr Eigen::Index kChunks = 4;

}  // namespace

bool has_shape(const std::vector<MlpLayer>& layers, int inputs, int h1, int h2) {
  return layers.size() == 3 && layers[0].weights.rows() == h1 &&
         layers[0].weights.cols() == inputs && layers[1].weights.rows() == h2 &&
         layers[1].weights.cols() == h1 && layers[2].weights.rows() == 1 &&
         layers[2].weights.cols() == h2 && layers[0].activation == Activation::kSigmoid &&
         layers[1].activation == Activation::kSigmoid;
}

void fused_gradients_2_10_10(const std::vector<MlpLayer>& layers, double output_scale,
                             const Eigen::MatrixXd& inputs, const Eigen::VectorXd& targets,
                             std::vector<Eigen::MatrixXd>& weights,
                             std::vector<Eigen::VectorXd>& biases) {
  constexpr int I = 2, H1 = 10, H2 = 10;
  const Eigen::Index n = inputs.rows();
  // Contiguous chunks of whole blocks, spread over the threads; each sums into its own lanes.
  const Eigen::Index chunks = n >= kChunks * kChunkSamples ? kChunks : 1;
  const Eigen::Index blocks_per_chunk = ((n + kLanes - 1) / kLanes + chunks - 1) / chunks;
  // The calling thread's workspace (no allocation after the first call), shared with the team:
  // a thread_local named inside the region would be each thread's own.
  thread_local std::vector<LaneSums<I, H1, H2>> workspace;
  std::vector<LaneSums<I, H1, H2>>& sums = workspace;
  sums.resize(static_cast<std::size_t>(chunks));
  weights.resize(3);
  biases.resize(3);
  weights[0].resize(H1, I);
  weights[1].resize(H2, H1);
  weights[2].resize(1, H2);
  biases[0].resize(H1);
  biases[1].resize(H2);
  biases[2].resize(1);
  using R = Rows<I, H1, H2>;
  // One team for both loops: each chunk zeroed and summed by its thread, then the rows reduced
  // over the threads (the implicit barrier between the loops waits for every chunk).
#pragma omp parallel if (chunks > 1)
  {
#pragma omp for schedule(static)
    for (Eigen::Index c = 0; c < chunks; ++c) {
      const Eigen::Index begin = std::min(n, c * blocks_per_chunk * kLanes);
      const Eigen::Index end = std::min(n, (c + 1) * blocks_per_chunk * kLanes);
      LaneSums<I, H1, H2>& mine = sums[static_cast<std::size_t>(c)];
      mine = LaneSums<I, H1, H2>{};
      if (layers[2].activation == Activation::kSigmoid) {
        blocks<I, H1, H2, true>(layers, output_scale, inputs, targets, begin, end, mine);
      } else {
        blocks<I, H1, H2, false>(layers, output_scale, inputs, targets, begin, end, mine);
      }
    }
#pragma omp for schedule(static)
    for (int k = 0; k < R::kRows; ++k) R::out(weights, biases, k) = reduce_row(sums, k);
  }
}

}  // namespace imm::trainer::mlp
