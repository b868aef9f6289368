// SPDX-License-Identifier: Apache-2.0
#include "batch_gradients.hpp"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include "exp_nonpositive.hpp"
#include "imm/math/lane_isa.hpp"
#include "imm/math/lane_math.hpp"

#if IMM_HAS_VECTOR_CLONES
#include <immintrin.h>
#endif

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

// A network's weights and biases as the kernels read them (column-major weights).
struct Parameters {
  const double* w1;
  const double* w2;
  const double* w3;
  const double* b1;
  const double* b2;
  double b3;
};
[[gnu::always_inline]] inline Parameters parameters_of(const std::vector<MlpLayer>& layers) {
  return {layers[0].weights.data(), layers[1].weights.data(), layers[2].weights.data(),
          layers[0].bias.data(),    layers[1].bias.data(),    layers[2].bias(0)};
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
  // (Named copies, not a structured binding: Clang 14 cannot capture one in an OpenMP simd loop.)
  const Parameters p = parameters_of(layers);
  const double *w1 = p.w1, *w2 = p.w2, *w3 = p.w3, *b1 = p.b1, *b2 = p.b2, b3 = p.b3;
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

#if IMM_HAS_VECTOR_CLONES
// --- The AVX-512 kernel: two blocks at a time, in explicit vectors of eight doubles ------------
// The lane loops above give GCC 12 one block's chains of dependent operations at a time (forward
// through both layers' exponentials, back through the sums). Written over vectors, two blocks
// interleave statement by statement and the core overlaps their chains. Every lane sees the lane
// kernel's operations in the same order, the multiply-adds the same fused instruction, and every
// sum gets the first block's term before the second's: the bits are the lane kernel's
// (tests/trainer/mlp_test.cpp compares them). For a linear output (W2a's, the input estimator's).
namespace wide {

#define IMM_AVX512_INLINE __attribute__((target("avx512f,fma"), always_inline)) inline
using Vec = double __attribute__((vector_size(64)));
using Bits = std::int64_t __attribute__((vector_size(64)));
using Unsigned = std::uint64_t __attribute__((vector_size(64)));
constexpr int kBlocks = 2;  // blocks per pass

IMM_AVX512_INLINE Vec splat(double x) { return Vec{x, x, x, x, x, x, x, x}; }
IMM_AVX512_INLINE Vec fused(Vec a, Vec b, Vec c) { return _mm512_fmadd_pd(a, b, c); }
IMM_AVX512_INLINE Vec pick(Bits use, Vec a, Vec b) {
  return reinterpret_cast<Vec>((use & reinterpret_cast<Bits>(a)) |
                               (~use & reinterpret_cast<Bits>(b)));
}
IMM_AVX512_INLINE Vec load(const std::array<double, kLanes>& a) {
  return _mm512_loadu_pd(a.data());
}
IMM_AVX512_INLINE void store(std::array<double, kLanes>& a, Vec v) {
  _mm512_storeu_pd(a.data(), v);
}

// exp_nonpositive (exp_nonpositive.hpp) of eight values, operation for operation. A second copy,
// not a template over both: GCC will not inline the AVX-512 multiply-add into a function compiled
// without that target, which a template shared with the lane kernel would be. The bit-equality
// test holds the two together.
IMM_AVX512_INLINE Vec exp_nonpositive(Vec x) {
  constexpr double kLog2e = 1.4426950408889634074;
  constexpr double kLn2High = 6.93147180369123816490e-01;
  constexpr double kLn2Low = 1.90821492927058770002e-10;
  constexpr double kRound = 0x1.8p52;
  const Bits underflow = x < -708.0;
  const Vec shifted = fused(x, splat(kLog2e), splat(kRound));
  const Vec n = shifted - kRound;
  const Vec r = fused(-n, splat(kLn2Low), fused(-n, splat(kLn2High), x));
  const Vec r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
  const Vec a0 = 1.0 + r, a1 = fused(r, splat(1.0 / 6.0), splat(1.0 / 2.0));
  const Vec a2 = fused(r, splat(1.0 / 120.0), splat(1.0 / 24.0));
  const Vec a3 = fused(r, splat(1.0 / 5040.0), splat(1.0 / 720.0));
  const Vec a4 = fused(r, splat(1.0 / 362880.0), splat(1.0 / 40320.0));
  const Vec a5 = fused(r, splat(1.0 / 39916800.0), splat(1.0 / 3628800.0));
  const Vec a6 = fused(r, splat(1.0 / 6227020800.0), splat(1.0 / 479001600.0));
  const Vec b0 = fused(r2, a1, a0), b1 = fused(r2, a3, a2), b2 = fused(r2, a5, a4);
  const Vec p = fused(r8, fused(r4, a6, b2), fused(r4, b1, b0));
  const Vec scale = reinterpret_cast<Vec>((reinterpret_cast<Unsigned>(shifted) + 1023U) << 52U);
  return pick(underflow, splat(0.0), p * scale);
}

// sigmoids (above) of a layer's H pre-activations of both blocks, in place: every exponential
// first, then every division, then the products, so that the divisions issue back to back and
// their latency overlaps (each lane's operations are the lane kernel's).
template <int H>
IMM_AVX512_INLINE void sigmoids(Vec (&a)[H][kBlocks]) {
  static_assert(H % 2 == 0);
  const Bits sign = reinterpret_cast<Bits>(splat(-0.0));
  Vec t[H][kBlocks], q[H / 2][kBlocks];
  for (int r = 0; r < H; ++r) {
    for (int h = 0; h < kBlocks; ++h) {
      t[r][h] = exp_nonpositive(reinterpret_cast<Vec>(reinterpret_cast<Bits>(a[r][h]) | sign));
    }
  }
  for (int r = 0; r < H; r += 2) {
    for (int h = 0; h < kBlocks; ++h) q[r / 2][h] = 1.0 / ((1.0 + t[r][h]) * (1.0 + t[r + 1][h]));
  }
  for (int r = 0; r < H; r += 2) {
    for (int h = 0; h < kBlocks; ++h) {
      const Vec d0 = 1.0 + t[r][h], d1 = 1.0 + t[r + 1][h];
      a[r][h] = pick(a[r][h] >= 0.0, splat(1.0), t[r][h]) * (d1 * q[r / 2][h]);
      a[r + 1][h] = pick(a[r + 1][h] >= 0.0, splat(1.0), t[r + 1][h]) * (d0 * q[r / 2][h]);
    }
  }
}

// Two blocks of kLanes samples from first[h] (valid[h] of them real; a block with none weighs
// nothing and adds exact zeros) forward and back into g.
template <int I, int H1, int H2>
IMM_AVX512_INLINE void blocks_of_two(const std::vector<MlpLayer>& layers, double inverse_scale,
                                     const Eigen::MatrixXd& inputs, const Eigen::VectorXd& targets,
                                     const Eigen::Index (&first)[kBlocks],
                                     const int (&valid)[kBlocks], double inverse_n,
                                     LaneSums<I, H1, H2>& g) {
  const Parameters p = parameters_of(layers);
  const double *w1 = p.w1, *w2 = p.w2, *w3 = p.w3, *b1 = p.b1, *b2 = p.b2, b3 = p.b3;
  Vec x[I][kBlocks], t[kBlocks], weight[kBlocks];
  for (int h = 0; h < kBlocks; ++h) {
    if (valid[h] == kLanes) {  // a full block: each column's eight samples in one load
      for (int c = 0; c < I; ++c) x[c][h] = _mm512_loadu_pd(&inputs(first[h], c));
      t[h] = _mm512_loadu_pd(&targets(first[h])) * inverse_scale;
      weight[h] = splat(inverse_n);
      continue;
    }
    for (int l = 0; l < kLanes; ++l) {
      const Eigen::Index s = first[h] + (l < valid[h] ? l : 0);
      for (int c = 0; c < I; ++c) x[c][h][l] = inputs(s, c);
      t[h][l] = targets(s) * inverse_scale;
      weight[h][l] = l < valid[h] ? inverse_n : 0.0;
    }
  }
  Vec a1[H1][kBlocks], a2[H2][kBlocks], d2[H2][kBlocks], d3[kBlocks];
  for (int r = 0; r < H1; ++r) {
    for (int h = 0; h < kBlocks; ++h) {
      Vec s = splat(b1[r]);
      for (int c = 0; c < I; ++c) s = fused(splat(w1[c * H1 + r]), x[c][h], s);
      a1[r][h] = s;
    }
  }
  sigmoids(a1);
  for (int r = 0; r < H2; ++r) {
    Vec s[kBlocks];
    for (int h = 0; h < kBlocks; ++h) s[h] = splat(b2[r]);
    for (int c = 0; c < H1; ++c) {
      for (int h = 0; h < kBlocks; ++h) s[h] = fused(splat(w2[c * H2 + r]), a1[c][h], s[h]);
    }
    for (int h = 0; h < kBlocks; ++h) a2[r][h] = s[h];
  }
  sigmoids(a2);
  for (int h = 0; h < kBlocks; ++h) {
    Vec s = splat(b3);
    for (int c = 0; c < H2; ++c) s = fused(splat(w3[c]), a2[c][h], s);
    d3[h] = (s - t[h]) * weight[h];
  }
  Vec sum3 = load(g.b3[0]);
  for (int h = 0; h < kBlocks; ++h) sum3 += d3[h];
  store(g.b3[0], sum3);
  for (int c = 0; c < H2; ++c) {
    Vec w = load(g.w3[c]), b = load(g.b2[c]);
    for (int h = 0; h < kBlocks; ++h) {
      w = fused(d3[h], a2[c][h], w);
      d2[c][h] = splat(w3[c]) * d3[h] * (a2[c][h] * (1.0 - a2[c][h]));
      b += d2[c][h];
    }
    store(g.w3[c], w);
    store(g.b2[c], b);
  }
  for (int c = 0; c < H1; ++c) {
    Vec sum[kBlocks];
    for (int h = 0; h < kBlocks; ++h) sum[h] = splat(0.0);
    for (int r = 0; r < H2; ++r) {
      auto& row = g.w2[static_cast<std::size_t>(c * H2 + r)];
      Vec w = load(row);
      for (int h = 0; h < kBlocks; ++h) {
        w = fused(d2[r][h], a1[c][h], w);
        sum[h] = fused(splat(w2[c * H2 + r]), d2[r][h], sum[h]);
      }
      store(row, w);
    }
    Vec b = load(g.b1[c]);
    Vec d1[kBlocks];
    for (int h = 0; h < kBlocks; ++h) {
      d1[h] = sum[h] * (a1[c][h] * (1.0 - a1[c][h]));
      b += d1[h];
    }
    store(g.b1[c], b);
    for (int i = 0; i < I; ++i) {
      auto& row = g.w1[static_cast<std::size_t>(i * H1 + c)];
      Vec w = load(row);
      for (int h = 0; h < kBlocks; ++h) w = fused(d1[h], x[i][h], w);
      store(row, w);
    }
  }
}

// The blocks from `begin` to `end` (sample indices, `begin` a multiple of kLanes), two at a time.
template <int I, int H1, int H2>
__attribute__((target("avx512f,fma"), flatten)) void blocks(
    const std::vector<MlpLayer>& layers, double output_scale, const Eigen::MatrixXd& inputs,
    const Eigen::VectorXd& targets, Eigen::Index begin, Eigen::Index end, LaneSums<I, H1, H2>& g) {
  const double inverse_n = 1.0 / static_cast<double>(inputs.rows());
  for (Eigen::Index first = begin; first < end; first += kBlocks * kLanes) {
    Eigen::Index starts[kBlocks];
    int valid[kBlocks];
    for (int h = 0; h < kBlocks; ++h) {
      const Eigen::Index start = first + h * kLanes;
      valid[h] = static_cast<int>(std::clamp<Eigen::Index>(end - start, 0, kLanes));
      starts[h] = valid[h] > 0 ? start : first;  // a block past the end reads a real sample
    }
    blocks_of_two<I, H1, H2>(layers, 1.0 / output_scale, inputs, targets, starts, valid, inverse_n,
                             g);
  }
}

#undef IMM_AVX512_INLINE
}  // namespace wide
#endif

// Entry i of one gradient part (`part`: w1, b1, w2, b2, w3 or b3) summed over the chunks' lane
// shares, into out[i]: over the chunks in order, lane by lane, then over the lanes by halves (lane
// l + lane l + w, w = 4, 2, 1): a fixed order, so the same bits at any thread count.
template <typename Sums, std::size_t N>
IMM_FMA_CLONES void reduce_part(const std::vector<Sums>& chunks,
                                std::array<std::array<double, kLanes>, N> Sums::*part,
                                double* out) {
  for (std::size_t i = 0; i < N; ++i) {
    std::array<double, kLanes> acc = (chunks.front().*part)[i];
    for (std::size_t c = 1; c < chunks.size(); ++c) {
      const auto& share = (chunks[c].*part)[i];
      for (std::size_t l = 0; l < kLanes; ++l) acc[l] += share[l];
    }
    for (std::size_t w = kLanes / 2; w >= 1; w /= 2) {
      for (std::size_t l = 0; l < w; ++l) acc[l] += acc[l + w];
    }
    out[i] = acc[0];
  }
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
  using Sums = LaneSums<I, H1, H2>;
  // The linear output's two-block kernel where the CPU has AVX-512 (and cap_lane_isa allows it).
  const bool wide_kernel = IMM_HAS_VECTOR_CLONES != 0 && lane_isa() == LaneIsa::kAvx512;
  // Chunk c zeroed and summed into its own lanes.
  const auto sum_chunk = [&](Eigen::Index c) {
    const Eigen::Index begin = std::min(n, c * blocks_per_chunk * kLanes);
    const Eigen::Index end = std::min(n, (c + 1) * blocks_per_chunk * kLanes);
    Sums& mine = sums[static_cast<std::size_t>(c)];
    mine = Sums{};
    if (layers[2].activation == Activation::kSigmoid) {
      blocks<I, H1, H2, true>(layers, output_scale, inputs, targets, begin, end, mine);
    } else if (wide_kernel) {
#if IMM_HAS_VECTOR_CLONES
      wide::blocks<I, H1, H2>(layers, output_scale, inputs, targets, begin, end, mine);
#endif
    } else {
      blocks<I, H1, H2, false>(layers, output_scale, inputs, targets, begin, end, mine);
    }
  };
  // One thread sums the chunks in turn without the OpenMP runtime: a team of one still pays a
  // futex call at each barrier, a system call per gradient that cost W2a a sixth of its time.
  // parallel_for does the same, but hands its items out dynamically: here each thread keeps the
  // same chunks, and their sums in its cache, every call (W2a on two threads: 105 ms static, 143
  // ms through parallel_for).
  if (chunks == 1 || omp_get_max_threads() == 1) {
    for (Eigen::Index c = 0; c < chunks; ++c) sum_chunk(c);
  } else {
#pragma omp parallel for schedule(static)
    for (Eigen::Index c = 0; c < chunks; ++c) sum_chunk(c);
  }
  reduce_part(sums, &Sums::w1, weights[0].data());
  reduce_part(sums, &Sums::b1, biases[0].data());
  reduce_part(sums, &Sums::w2, weights[1].data());
  reduce_part(sums, &Sums::b2, biases[1].data());
  reduce_part(sums, &Sums::w3, weights[2].data());
  reduce_part(sums, &Sums::b3, biases[2].data());
}

}  // namespace imm::trainer::mlp
