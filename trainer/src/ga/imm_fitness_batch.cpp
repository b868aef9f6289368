// SPDX-License-Identifier: Apache-2.0
// The GA-fuzzy IMM over blocks of trajectories, lanes innermost (see the header). Each IMM_LANES
// loop below is one or two vector operations; the order of the filter's operations follows
// FuzzyNoiseFilter::step and update_with_innovation, the mixing ImmEstimator<2, 1>.
#include "imm/trainer/ga/imm_fitness_batch.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "imm/core/physical_limits.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "imm/trainer/normalized_errors.hpp"

// Run-time choice of AVX2 (GCC on x86-64 Linux), as the runtime's FCM and bank kernels: "avx2"
// does not enable FMA contraction, so every instruction set computes the same bits.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define IMM_BATCH_CLONES __attribute__((target_clones("avx2", "default"), flatten))
#else
#define IMM_BATCH_CLONES
#endif

// Every loop over the lanes of a block: one vector operation. `omp simd` keeps the compiler from
// unrolling the four iterations into scalar code before it vectorizes them.
#define IMM_LANES _Pragma("omp simd") for (int l = 0; l < W; ++l)

namespace imm::trainer::ga {
namespace {

constexpr int kMaxLevels = 8;

// The model's constants: transitions, initial log probabilities, the rule tables, F, GGᵀ, R.
struct Model {
  int modes = 0;
  double transition[kMaxLevels][kMaxLevels] = {};
  double initial[kMaxLevels] = {};
  // The rules, with their spreads inverted (a multiplication per rule instead of a division).
  struct Rule {
    double c1, inverse_sigma1, c2, inverse_sigma2, w;
  };
  Rule rules[kMaxLevels][FuzzyRuleTable::kMaxRules] = {};
  int rule_count[kMaxLevels] = {};
  double mean_w[kMaxLevels] = {};
  bool normalized = false;
  double T = 1.0, R = 1.0, start_variance = 1.0;
  double g00 = 0.0, g01 = 0.0, g11 = 0.0;  // G Gᵀ
};

// One block's trajectories: [scan][lane] views, and the per-scan sums of the ζ figures.
struct BlockData {
  const double* z;
  const double* p;
  const double* v;
  const double* mask;
  int scans;
};

struct Sums {
  double position_abs = 0.0, velocity_abs = 0.0, count = 0.0;
  bool failed = false;
  // ζ: per scan Σ (p − p̂)², Σ (p − z)², Σ (v − v̂)², Σ (v − v̄)², samples.
  double* pe = nullptr;
  double* pm = nullptr;
  double* ve = nullptr;
  double* vm = nullptr;
  double* samples = nullptr;
};

// One block of W lanes (W = 8 or 4: two AVX2 vectors, so that each loop has two independent
// chains of operations, or one for the last few trajectories).
template <int W>
[[gnu::always_inline]] inline void run_lanes(const Model& m, const BlockData& d, Sums& sums) {
  using Lanes = double[W];
  const int n = m.modes;
  Lanes x0[kMaxLevels], x1[kMaxLevels], p00[kMaxLevels], p01[kMaxLevels], p11[kMaxLevels];
  Lanes mu[kMaxLevels], previous[kMaxLevels];
  Lanes nx0[kMaxLevels], nx1[kMaxLevels], np00[kMaxLevels], np01[kMaxLevels], np11[kMaxLevels];
  Lanes exponent[kMaxLevels], scale[kMaxLevels], next_previous[kMaxLevels];
  Lanes predicted[kMaxLevels], inverse_predicted[kMaxLevels], weight[kMaxLevels];
  Lanes bad, abs_p, abs_v, count;
  const double T = m.T, r = m.start_variance;
  // Two-point start from scans 0 and 1.
  for (int j = 0; j < n; ++j) {
    IMM_LANES {
      x0[j][l] = d.z[W + l];
      x1[j][l] = (d.z[W + l] - d.z[l]) / T;
      p00[j][l] = r;
      p01[j][l] = r / T;
      p11[j][l] = 2.0 * r / (T * T);
      mu[j][l] = m.initial[j];
      previous[j][l] = 0.0;
    }
  }
  IMM_LANES bad[l] = abs_p[l] = abs_v[l] = count[l] = 0.0;

  for (int k = 2; k < d.scans; ++k) {
    const double* z = d.z + static_cast<std::ptrdiff_t>(k) * W;
    // c_j = Σ_i p_ij μ_i (eq. 8's inner sum).
    for (int j = 0; j < n; ++j) {
      IMM_LANES predicted[j][l] = 0.0;
      for (int i = 0; i < n; ++i) {
        IMM_LANES predicted[j][l] += m.transition[i][j] * mu[i][l];
      }
      IMM_LANES inverse_predicted[j][l] = 1.0 / predicted[j][l];
    }
    for (int j = 0; j < n; ++j) {
      // Mixing (eq. 4–6): the weights μ_{i|j}, the mixed mean, then the spread of the means.
      Lanes m0, m1, c00, c01, c11;
      IMM_LANES m0[l] = m1[l] = c00[l] = c01[l] = c11[l] = 0.0;
      for (int i = 0; i < n; ++i) {
        IMM_LANES {
          weight[i][l] = m.transition[i][j] * mu[i][l] * inverse_predicted[j][l];
          m0[l] += weight[i][l] * x0[i][l];
          m1[l] += weight[i][l] * x1[i][l];
        }
      }
      for (int i = 0; i < n; ++i) {
        IMM_LANES {
          const double w = weight[i][l];
          const double d0 = x0[i][l] - m0[l], d1 = x1[i][l] - m1[l];
          c00[l] += pick(w == 0.0, 0.0, w * (p00[i][l] + d0 * d0));
          c01[l] += pick(w == 0.0, 0.0, w * (p01[i][l] + d0 * d1));
          c11[l] += pick(w == 0.0, 0.0, w * (p11[i][l] + d1 * d1));
        }
      }
      // Prediction F x, F P Fᵀ; the residual and the table's inputs.
      Lanes a0, residual, antecedent, q00, q01, q11;
      IMM_LANES {
        a0[l] = m0[l] + T * m1[l];
        const double fp00 = c00[l] + T * c01[l], fp01 = c01[l] + T * c11[l];
        q00[l] = fp00 + fp01 * T;
        q01[l] = fp01;
        q11[l] = c11[l];
        residual[l] = z[l] - a0[l];
        antecedent[l] = m.normalized ? residual[l] / std::sqrt(q00[l] + m.R) : residual[l];
      }
      // q(k) of the rule table (eq. 19-5), the mean w where no rule fires.
      Lanes numerator, denominator;
      IMM_LANES numerator[l] = denominator[l] = 0.0;
      for (int rule = 0; rule < m.rule_count[j]; ++rule) {
        const Model::Rule& f = m.rules[j][rule];
        IMM_LANES {
          const double a = (antecedent[l] - f.c1) * f.inverse_sigma1;
          const double b = (antecedent[l] - previous[j][l] - f.c2) * f.inverse_sigma2;
          const double firing = lane_exp(-0.5 * (a * a + b * b));
          numerator[l] += f.w * firing;
          denominator[l] += firing;
        }
      }
      IMM_LANES {
        const double q = pick(denominator[l] >= std::numeric_limits<double>::min(),
                              numerator[l] / denominator[l], m.mean_w[j]);
        q00[l] += q * m.g00;
        q01[l] += q * m.g01;
        q11[l] += q * m.g11;
        // The Kalman update with H = [1 0] in the order of update_with_innovation.
        const double S = q00[l] + m.R;
        const bool usable = (S > 0.0) & (S < std::numeric_limits<double>::infinity());
        const double S_inverse = 1.0 / S;
        const double k0 = q00[l] * S_inverse, k1 = q01[l] * S_inverse;
        const double C00 = q00[l] - k0 * q00[l], C01 = q01[l] - k0 * q01[l];
        const double C10 = q01[l] - k1 * q00[l], C11 = q11[l] - k1 * q01[l];
        const double kr0 = k0 * m.R, kr1 = k1 * m.R;
        nx0[j][l] = a0[l] + k0 * residual[l];
        nx1[j][l] = m1[l] + k1 * residual[l];
        np00[j][l] = C00 - C00 * k0 + kr0 * k0;
        const double u01 = C01 - C00 * k1 + kr0 * k1;
        const double u10 = C10 - C10 * k0 + kr1 * k0;
        np01[j][l] = 0.5 * (u01 + u10);
        np11[j][l] = C11 - C10 * k1 + kr1 * k1;
        // N(r; 0, S) c_j = exp(−½ r²/S) · c_j/√S · (2π)^−½; the constant cancels below.
        exponent[j][l] = -0.5 * (residual[l] * (S_inverse * residual[l]));
        scale[j][l] = predicted[j][l] * std::sqrt(S_inverse);
        next_previous[j][l] = antecedent[l];
        const bool finite = std::isfinite(nx0[j][l] + nx1[j][l] + np00[j][l] + np01[j][l] +
                                          np11[j][l] + exponent[j][l]);
        // A plot the runtime refuses (limits::usable_measurement) fails its step there too.
        const bool plot = std::abs(z[l]) <= limits::kMaxMeasurement;
        bad[l] += pick(usable & finite & plot, 0.0, d.mask[k * W + l]);
      }
    }
    // The posterior μ_j ∝ c_j N(r_j; 0, S_j), each likelihood's exponent taken relative to the
    // largest (finish_cycle's log-space normalization, in linear space), then commit and combine.
    Lanes shift, sum, inverse_sum, e0, e1;
    IMM_LANES shift[l] = exponent[0][l];
    for (int j = 1; j < n; ++j) {
      IMM_LANES shift[l] = std::max(shift[l], exponent[j][l]);
    }
    IMM_LANES sum[l] = 0.0;
    for (int j = 0; j < n; ++j) {
      IMM_LANES {
        exponent[j][l] = scale[j][l] * lane_exp(exponent[j][l] - shift[l]);
        sum[l] += exponent[j][l];
      }
    }
    IMM_LANES {
      const bool normal = (sum[l] > 0.0) & (sum[l] < std::numeric_limits<double>::infinity());
      bad[l] += pick(normal, 0.0, d.mask[k * W + l]);
      inverse_sum[l] = 1.0 / sum[l];
      e0[l] = e1[l] = 0.0;
    }
    for (int j = 0; j < n; ++j) {
      IMM_LANES {
        mu[j][l] = exponent[j][l] * inverse_sum[l];
        x0[j][l] = nx0[j][l];
        x1[j][l] = nx1[j][l];
        p00[j][l] = np00[j][l];
        p01[j][l] = np01[j][l];
        p11[j][l] = np11[j][l];
        previous[j][l] = next_previous[j][l];
        e0[l] += mu[j][l] * x0[j][l];
        e1[l] += mu[j][l] * x1[j][l];
      }
    }
    // The errors of the combined estimate, masked.
    const double* p = d.p + static_cast<std::ptrdiff_t>(k) * W;
    const double* v = d.v + static_cast<std::ptrdiff_t>(k) * W;
    const double* mask = d.mask + static_cast<std::ptrdiff_t>(k) * W;
    const double* z_before = z - W;
    Lanes dp2, dz2, dv2, dm2;
    IMM_LANES {
      abs_p[l] += pick(mask[l] != 0.0, std::abs(p[l] - e0[l]), 0.0);
      abs_v[l] += pick(mask[l] != 0.0, std::abs(v[l] - e1[l]), 0.0);
      count[l] += mask[l];
      const double dp = p[l] - e0[l], dz = p[l] - z[l];
      const double dv = v[l] - e1[l], dm = v[l] - (z[l] - z_before[l]) / T;
      dp2[l] = dp * dp;
      dz2[l] = dz * dz;
      dv2[l] = dv * dv;
      dm2[l] = dm * dm;
    }
    // The per-scan sums in trajectory order (NormalizedErrors' order), in registers: a plain loop,
    // not a vector one, since each lane adds to the same sums.
    double pe = sums.pe[k], pm = sums.pm[k], ve = sums.ve[k], vm = sums.vm[k];
    double samples = sums.samples[k];
    for (int l = 0; l < W; ++l) {
      if (mask[l] == 0.0) continue;
      pe += dp2[l];
      pm += dz2[l];
      ve += dv2[l];
      vm += dm2[l];
      samples += 1.0;
    }
    sums.pe[k] = pe;
    sums.pm[k] = pm;
    sums.ve[k] = ve;
    sums.vm[k] = vm;
    sums.samples[k] = samples;
  }
  for (int l = 0; l < W; ++l) {
    sums.position_abs += abs_p[l];
    sums.velocity_abs += abs_v[l];
    sums.count += count[l];
    sums.failed = sums.failed || bad[l] != 0.0;
  }
}

IMM_BATCH_CLONES void run_block8(const Model& m, const BlockData& d, Sums& sums) {
  run_lanes<8>(m, d, sums);
}

IMM_BATCH_CLONES void run_block4(const Model& m, const BlockData& d, Sums& sums) {
  run_lanes<4>(m, d, sums);
}

// Per-thread workspace of the per-scan sums: grows to the longest set, then allocates nothing.
std::vector<double>& workspace() {
  thread_local std::vector<double> buffer;
  return buffer;
}

}  // namespace

ImmFitnessBatch::ImmFitnessBatch(const TrainingSet& set) {
  const auto count = static_cast<int>(set.trajectories.size());
  if (count == 0) throw std::invalid_argument("a fitness batch needs trajectories");
  for (const auto& t : set.trajectories) {
    if (t.measurement.size() < 3) throw std::invalid_argument("trajectories need 3 scans");
    scans_ = std::max(scans_, static_cast<int>(t.measurement.size()));
  }
  // Blocks of 8 while more than 4 trajectories remain, then one of 4.
  int lanes = 0;
  for (int remaining = count; remaining > 0; remaining -= widths_.back()) {
    widths_.push_back(remaining > 4 ? 8 : 4);
    lanes += widths_.back();
  }
  start_variance_ = set.measurement_variance;
  const auto size = static_cast<std::size_t>(lanes) * static_cast<std::size_t>(scans_);
  measurement_.assign(size, 0.0);
  position_.assign(size, 0.0);
  velocity_.assign(size, 0.0);
  mask_.assign(size, 0.0);
  std::size_t block_start = 0;
  int first = 0;
  for (const int width : widths_) {
    for (int l = 0; l < width; ++l) {
      // An empty lane of the last block repeats the last trajectory, masked out.
      const int index = std::min(first + l, count - 1);
      const bool real = first + l < count;
      const AxisTrajectory& t = set.trajectories[static_cast<std::size_t>(index)];
      const auto length = static_cast<int>(t.measurement.size());
      for (int k = 0; k < scans_; ++k) {
        // Past its end a trajectory holds its last scan (a plot the filter can take), masked.
        const Eigen::Index from = std::min(k, length - 1);
        const std::size_t at = block_start + static_cast<std::size_t>(k * width + l);
        measurement_[at] = t.measurement(from);
        position_[at] = t.position(from);
        velocity_[at] = t.velocity(from);
        mask_[at] = real && k < length ? 1.0 : 0.0;
      }
    }
    block_start += static_cast<std::size_t>(width) * static_cast<std::size_t>(scans_);
    first += width;
  }
}

bool ImmFitnessBatch::supports(const GaFuzzyImmSpec& spec) {
  const auto n = static_cast<int>(spec.levels.size());
  if (n < 1 || n > kMaxLevels) return false;
  const Eigen::MatrixXd transition = spec.settings.transition(n);
  return (transition.array() > 0.0).all();
}

ImmRunErrors ImmFitnessBatch::run(const GaFuzzyImmSpec& spec) const {
  if (!supports(spec)) throw std::invalid_argument("the fitness batch does not support this IMM");
  spec.validate();
  Model m;
  m.modes = static_cast<int>(spec.levels.size());
  const Eigen::MatrixXd transition = spec.settings.transition(m.modes);
  const Eigen::VectorXd initial = spec.settings.initial_probabilities(m.modes);
  for (int i = 0; i < m.modes; ++i) {
    m.initial[i] = initial(i);
    for (int j = 0; j < m.modes; ++j) m.transition[i][j] = transition(i, j);
    const FuzzyRuleTable& table = spec.levels[static_cast<std::size_t>(i)].table;
    m.rule_count[i] = static_cast<int>(table.size());
    for (std::size_t k = 0; k < table.size(); ++k) {
      const FuzzyRule& rule = table.rules()[k];
      m.rules[i][k] = {rule.c1, 1.0 / rule.sigma1, rule.c2, 1.0 / rule.sigma2, rule.w};
    }
    m.mean_w[i] = table.mean_w();
  }
  m.normalized = spec.antecedents == FuzzyAntecedents::kNormalizedInnovation;
  m.T = spec.settings.sample_period;
  m.R = spec.settings.measurement_sigma * spec.settings.measurement_sigma;
  m.start_variance = start_variance_;
  const Vector<2> G = cv_axis_input_gain(m.T);
  m.g00 = G(0) * G(0);
  m.g01 = G(0) * G(1);
  m.g11 = G(1) * G(1);

  std::vector<double>& buffer = workspace();
  const auto scans = static_cast<std::size_t>(scans_);
  buffer.assign(5 * scans, 0.0);  // within capacity after the first call: no allocation
  Sums sums;
  sums.pe = buffer.data();
  sums.pm = sums.pe + scans;
  sums.ve = sums.pm + scans;
  sums.vm = sums.ve + scans;
  sums.samples = sums.vm + scans;
  std::size_t at = 0;
  for (std::size_t b = 0; b < widths_.size() && !sums.failed; ++b) {
    const BlockData block{measurement_.data() + at, position_.data() + at, velocity_.data() + at,
                          mask_.data() + at, scans_};
    if (widths_[b] == 8) {
      run_block8(m, block, sums);
    } else {
      run_block4(m, block, sums);
    }
    at += static_cast<std::size_t>(widths_[b]) * scans;
  }
  ImmRunErrors errors;
  errors.failed = sums.failed;
  errors.position_abs_sum = sums.position_abs;
  errors.velocity_abs_sum = sums.velocity_abs;
  errors.count = static_cast<long>(sums.count);
  const auto n = static_cast<long>(scans);
  errors.zeta_p = mean_normalized_ratio(sums.pe, sums.pm, sums.samples, n);
  errors.zeta_v = mean_normalized_ratio(sums.ve, sums.vm, sums.samples, n);
  return errors;
}

}  // namespace imm::trainer::ga
