// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Seeded, platform-independent random numbers. The standard distributions' algorithms are
/// implementation-defined, so the same seed could give other data with another standard library;
/// the generator here (mt19937_64, whose sequence the standard fixes) and the transforms below are
/// ours, and results are bit-identical everywhere.
///
/// Independent streams (one per Monte Carlo run, per individual, per thread) come from
/// derive_seed(seed, stream), so a run's data depend only on (seed, run), never on the order or
/// the thread that generates them.

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>

namespace imm::datasets {

/// SplitMix64 of (seed, stream): well-mixed, distinct seeds for independent streams.
[[nodiscard]] constexpr std::uint64_t derive_seed(std::uint64_t seed, std::uint64_t stream) {
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ULL * (stream + 1);
  z = (z ^ (z >> 30U)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27U)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31U);
}

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}

  /// 64 uniform random bits: one per fair coin (the GA's crossover takes 64 slots per draw).
  std::uint64_t bits() { return engine_(); }

  /// Uniform on [0, 1), 53 random bits.
  double uniform() { return static_cast<double>(engine_() >> 11U) * 0x1.0p-53; }

  /// Uniform on [low, high).
  double uniform(double low, double high) { return low + (high - low) * uniform(); }

  /// Standard normal by the Box–Muller transform (two per pair of uniforms, the second cached).
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u1 = 0.0;
    do {
      u1 = uniform();
    } while (u1 <= 0.0);
    const double u2 = uniform();
    const double radius = std::sqrt(-2.0 * std::log(u1));
    const double angle = 2.0 * std::numbers::pi * u2;
    spare_ = radius * std::sin(angle);
    has_spare_ = true;
    return radius * std::cos(angle);
  }

  double normal(double mean, double sigma) { return mean + sigma * normal(); }

  /// Uniform integer in [0, n).
  std::uint64_t below(std::uint64_t n) {
    // Lemire's rejection keeps it unbiased.
    const std::uint64_t threshold = (0 - n) % n;
    while (true) {
      const std::uint64_t r = engine_();
      if (r >= threshold) return r % n;
    }
  }

 private:
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace imm::datasets
