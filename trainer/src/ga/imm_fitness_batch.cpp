// SPDX-License-Identifier: Apache-2.0
// The GA-fuzzy IMM over blocks of trajectories, lanes innermost (see the header). Each IMM_LANES
// loop below is one or two vector operations; the order of the filter's operations follows
// FuzzyNoiseFilter::step and update_with_innovation, the mixing ImmEstimator<2, 1>.
#include "imm/trainer/ga/imm_fitness_batch.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include "imm/core/physical_limits.hpp"
#include "imm/filters/fuzzy_noise_step.hpp"
#include "imm/math/lane_isa.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"
#include "imm/trainer/normalized_errors.hpp"

namespace imm::trainer::ga {
namespace {

using lanes::kMaxLevels;

// The model's constants: transitions, initial probabilities, the axis and the levels' tables.
struct Model {
  int modes = 0;
  double transition[kMaxLevels][kMaxLevels] = {};
  double initial[kMaxLevels] = {};
  lanes::FuzzyLevelConstants levels[kMaxLevels];
  lanes::FuzzyAxisConstants axis;
  double start_variance = 1.0;
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
  double log_likelihood = 0.0;  // Σ log p(z | Z^(k−1)) + ½ log 2π per plot
  bool failed = false;
  // ζ: per scan Σ (p − p̂)², Σ (p − z)², Σ (v − v̂)², Σ (v − v̄)², samples.
  double* pe = nullptr;
  double* pm = nullptr;
  double* ve = nullptr;
  double* vm = nullptr;
  double* samples = nullptr;
};

// One block of W lanes (W = 24, 16, 8 or 4: see the constructor's comment in the header).
// kLikelihood: also sum the plots' predictive log-likelihood (a training set without truth); a
// lane_log per plot that the truth's runs do not pay.
template <int W, bool kLikelihood, class Pack>
[[gnu::always_inline]] inline void run_lanes(const Model& m, const BlockData& d, Sums& sums) {
  using Lanes = double[W];
  const int n = m.modes;
  // The modes' states before and after the scan's step (swapped at its end).
  lanes::AxisModes<W> modes[2];
  lanes::AxisModes<W>* now = &modes[0];
  lanes::AxisModes<W>* next = &modes[1];
  Lanes mu[kMaxLevels], exponent[kMaxLevels], scale[kMaxLevels];
  Lanes predicted[kMaxLevels], inverse_predicted[kMaxLevels], weight[kMaxLevels];
  Lanes bad, abs_p, abs_v, count, log_likelihood;
  const double T = m.axis.T, r = m.start_variance;
  // Two-point start from scans 0 and 1.
  for (int j = 0; j < n; ++j) {
    IMM_LANES {
      now->x0[j][l] = d.z[W + l];
      now->x1[j][l] = (d.z[W + l] - d.z[l]) / T;
      now->p00[j][l] = r;
      now->p01[j][l] = r / T;
      now->p11[j][l] = 2.0 * r / (T * T);
      mu[j][l] = m.initial[j];
      now->previous[j][l] = 0.0;
    }
  }
  IMM_LANES bad[l] = abs_p[l] = abs_v[l] = count[l] = log_likelihood[l] = 0.0;

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
      // Mixing (eq. 4–6), then the mode's fuzzy-noise step (fuzzy_noise_step.hpp).
      for (int i = 0; i < n; ++i) {
        IMM_LANES weight[i][l] = m.transition[i][j] * mu[i][l] * inverse_predicted[j][l];
      }
      Lanes m0, m1, c00, c01, c11;
      lanes::mix<W>(n, weight, *now, m0, m1, c00, c01, c11);
      // Every lane of every field is written by fuzzy_noise_lanes; zeroing it first would cost.
      lanes::FuzzyLaneSteps<W> step;  // NOLINT(cppcoreguidelines-pro-type-member-init)
      lanes::fuzzy_noise_lanes<W, Pack>(m.axis, m.levels[j], z, m0, m1, c00, c01, c11, j, *now,
                                        *next, step);
      IMM_LANES {
        // N(r; 0, S) c_j = exp(−½ r²/S) · c_j/√S · (2π)^−½; the constant cancels below.
        exponent[j][l] = -0.5 * step.mahalanobis[l];
        scale[j][l] = predicted[j][l] * std::sqrt(step.s_inverse[l]);
        // A plot the runtime refuses (limits::usable_measurement) fails its step there too.
        const bool plot = std::abs(z[l]) <= limits::kMaxMeasurement;
        bad[l] +=
            pick((step.usable[l] != 0.0) & (step.finite[l] != 0.0) & plot, 0.0, d.mask[k * W + l]);
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
        exponent[j][l] = scale[j][l] * lane_exp_no_overflow(exponent[j][l] - shift[l]);
        sum[l] += exponent[j][l];
      }
    }
    IMM_LANES {
      const bool normal = (sum[l] > 0.0) & (sum[l] < std::numeric_limits<double>::infinity());
      bad[l] += pick(normal, 0.0, d.mask[k * W + l]);
      inverse_sum[l] = 1.0 / sum[l];
      e0[l] = e1[l] = 0.0;
    }
    if constexpr (kLikelihood) {
      // log Σ_j c_j N(r_j; 0, S_j) but for −½ log 2π: the plot's predictive log-likelihood.
      IMM_LANES {
        const bool normal = (sum[l] > 0.0) & (sum[l] < std::numeric_limits<double>::infinity());
        log_likelihood[l] +=
            pick((d.mask[k * W + l] != 0.0) & normal, lane_log(sum[l]) + shift[l], 0.0);
      }
    }
    std::swap(now, next);  // commit
    for (int j = 0; j < n; ++j) {
      IMM_LANES {
        mu[j][l] = exponent[j][l] * inverse_sum[l];
        e0[l] += mu[j][l] * now->x0[j][l];
        e1[l] += mu[j][l] * now->x1[j][l];
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
    sums.log_likelihood += log_likelihood[l];
    sums.failed = sums.failed || bad[l] != 0.0;
  }
}

// A block's function for each instruction set, the step's packs one vector of it (lane_isa.hpp):
// with or without the plots' likelihood.
// NOLINTBEGIN(bugprone-macro-parentheses): `target` is an attribute.
#define IMM_BLOCK_FOR(isa, target, width)                                                    \
  template <int W, bool kLikelihood>                                                         \
  [[gnu::flatten]] target void block_##isa(const Model& m, const BlockData& d, Sums& sums) { \
    run_lanes<W, kLikelihood, LanePackOf<(W < (width) ? W : (width))>>(m, d, sums);          \
  }
IMM_FOR_EACH_LANE_ISA(IMM_BLOCK_FOR)
#undef IMM_BLOCK_FOR
// NOLINTEND(bugprone-macro-parentheses)

template <int W, bool kLikelihood>
void run_block(LaneIsa isa, const Model& m, const BlockData& d, Sums& sums) {
  for_lane_isa(isa, block_avx512<W, kLikelihood>, block_avx2<W, kLikelihood>,
               block_baseline<W, kLikelihood>)(m, d, sums);
}

// The block of `width` lanes: with or without the plots' likelihood.
void run_width(LaneIsa isa, int width, bool likelihood, const Model& m, const BlockData& d,
               Sums& sums) {
  switch (width) {
    case 24:
      return (likelihood ? run_block<24, true> : run_block<24, false>)(isa, m, d, sums);
    case 16:
      return (likelihood ? run_block<16, true> : run_block<16, false>)(isa, m, d, sums);
    case 8:
      return (likelihood ? run_block<8, true> : run_block<8, false>)(isa, m, d, sums);
    default:
      return (likelihood ? run_block<4, true> : run_block<4, false>)(isa, m, d, sums);
  }
}

// Per-thread workspace of the per-scan sums: grows to the longest set, then allocates nothing.
std::vector<double>& workspace() {
  thread_local std::vector<double> buffer;
  return buffer;
}

}  // namespace

ImmFitnessBatch::ImmFitnessBatch(const TrainingSet& set, bool wide_blocks) {
  const auto count = static_cast<int>(set.trajectories.size());
  if (count == 0) throw std::invalid_argument("a fitness batch needs trajectories");
  for (const auto& t : set.trajectories) {
    if (t.measurement.size() < 3) throw std::invalid_argument("trajectories need 3 scans");
    scans_ = std::max(scans_, static_cast<int>(t.measurement.size()));
  }
  // Blocks of 8 while more than 4 trajectories remain, then one of 4; where the AVX-512 clones
  // run, of 24 while more than 16 remain, then 16 while more than 8.
  int lanes = 0;
  for (int remaining = count; remaining > 0; remaining -= widths_.back()) {
    const int width = remaining > 16 && wide_blocks  ? 24
                      : remaining > 8 && wide_blocks ? 16
                      : remaining > 4                ? 8
                                                     : 4;
    widths_.push_back(width);
    lanes += width;
  }
  start_variance_ = set.measurement_variance;
  plots_only_ = set.plots_only;
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
    m.levels[i] = lanes::FuzzyLevelConstants(spec.levels[static_cast<std::size_t>(i)].table);
  }
  m.axis = lanes::FuzzyAxisConstants(
      spec.settings.sample_period,
      spec.settings.measurement_sigma * spec.settings.measurement_sigma, spec.antecedents);
  m.start_variance = start_variance_;

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
  const LaneIsa isa = lane_isa();
  for (std::size_t b = 0; b < widths_.size() && !sums.failed; ++b) {
    const BlockData block{measurement_.data() + at, position_.data() + at, velocity_.data() + at,
                          mask_.data() + at, scans_};
    run_width(isa, widths_[b], plots_only_, m, block, sums);
    at += static_cast<std::size_t>(widths_[b]) * scans;
  }
  ImmRunErrors errors;
  errors.failed = sums.failed;
  errors.position_abs_sum = sums.position_abs;
  errors.velocity_abs_sum = sums.velocity_abs;
  errors.count = static_cast<long>(sums.count);
  errors.predictive_nll =
      sums.count > 0.0 ? -sums.log_likelihood / sums.count + 0.5 * kLogTwoPi : 0.0;
  const auto n = static_cast<long>(scans);
  errors.zeta_p = mean_normalized_ratio(sums.pe, sums.pm, sums.samples, n);
  errors.zeta_v = mean_normalized_ratio(sums.ve, sums.vm, sums.samples, n);
  return errors;
}

}  // namespace imm::trainer::ga
