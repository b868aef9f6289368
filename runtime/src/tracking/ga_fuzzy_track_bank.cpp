// SPDX-License-Identifier: Apache-2.0
// The GA-fuzzy IMM bank: axis filters as lanes, blocks of kBlock lanes stepped in vector loops
// (see the header). The order of operations follows ImmEstimator (mode-probability prediction,
// mixing, the modes' steps, the log-space posterior, the combination) and fuzzy_noise_step.hpp.
#include "imm/tracking/ga_fuzzy_track_bank.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "axis_lane_bank.hpp"
#include "bank_checks.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"

namespace imm {
namespace {

using lanes::kMaxLevels;
// State slots of mode j at j * kModeSlots + entry; the combined estimate after the modes.
constexpr int kX0 = 0, kX1 = 1, kP00 = 2, kP01 = 3, kP11 = 4, kLogMu = 5, kScaledMu = 6,
              kPrevious = 7, kModeSlots = 8;
using bank::kNonFinite, bank::kOk, bank::kSingular, bank::kUnderflow;

struct BankConstants {
  int modes = 0;
  const double* transition = nullptr;  // π_ij at i * modes + j
  const lanes::FuzzyAxisConstants* axis = nullptr;
  const lanes::FuzzyLevelConstants* levels = nullptr;
};

// One IMM cycle of one block's W lanes. `state` points at the block's first lane of slot 0; `z`
// the lanes' plots; `stepped` 1 for a lane to step; `code` receives each lane's outcome.
template <int W>
[[gnu::flatten]] IMM_VECTOR_CLONES void step_block(const BankConstants& b, double* state,
                                                   std::ptrdiff_t stride, const double* z,
                                                   const double* stepped, double* code) {
  using Lanes = double[W];
  const int n = b.modes;
  auto st = [&](int j, int entry) { return state + (j * kModeSlots + entry) * stride; };
  auto combined = [&](int entry) { return state + (n * kModeSlots + entry) * stride; };

  // The modes' current states, as the mixing reads them, and the states the step gives: the n
  // modes' fields are written before they are read, the others never read.
  lanes::AxisModes<W> now, next;  // NOLINT(cppcoreguidelines-pro-type-member-init)
  for (int i = 0; i < n; ++i) {
    IMM_LANES {
      now.x0[i][l] = st(i, kX0)[l];
      now.x1[i][l] = st(i, kX1)[l];
      now.p00[i][l] = st(i, kP00)[l];
      now.p01[i][l] = st(i, kP01)[l];
      now.p11[i][l] = st(i, kP11)[l];
      now.previous[i][l] = st(i, kPrevious)[l];
    }
  }
  // log c_j = log Σ_i p_ij μ̃_i + max log μ (ImmEstimator::predict_mode_probabilities).
  Lanes shift, predicted[kMaxLevels], log_predicted[kMaxLevels];
  IMM_LANES shift[l] = st(0, kLogMu)[l];
  for (int i = 1; i < n; ++i) {
    IMM_LANES shift[l] = std::max(shift[l], st(i, kLogMu)[l]);
  }
  for (int j = 0; j < n; ++j) {
    IMM_LANES predicted[j][l] = 0.0;
    for (int i = 0; i < n; ++i) {
      const double p = b.transition[i * n + j];
      const double* mu = st(i, kScaledMu);
      IMM_LANES predicted[j][l] += p * mu[l];
    }
    IMM_LANES log_predicted[j][l] = lane_log(predicted[j][l]) + shift[l];
  }

  // Each mode: mixing (eq. 4–6), its fuzzy-noise step, ℓ_j = log N(r; 0, S) + log c_j.
  Lanes posterior[kMaxLevels], outcome;
  IMM_LANES outcome[l] = kOk;
  for (int j = 0; j < n; ++j) {
    Lanes weight[kMaxLevels];
    for (int i = 0; i < n; ++i) {
      const double p = b.transition[i * n + j];
      const double* mu = st(i, kScaledMu);
      IMM_LANES weight[i][l] = p * mu[l] / predicted[j][l];
    }
    Lanes m0, m1, c00, c01, c11;
    lanes::mix<W>(n, weight, now, m0, m1, c00, c01, c11);
    // Every lane of every field is written by fuzzy_noise_lanes; zeroing it first would cost.
    lanes::FuzzyLaneSteps<W> s;  // NOLINT(cppcoreguidelines-pro-type-member-init)
    lanes::fuzzy_noise_lanes<W>(*b.axis, b.levels[j], z, m0, m1, c00, c01, c11, j, now, next, s);
    IMM_LANES {
      const double log_likelihood = -0.5 * (s.mahalanobis[l] + lane_log(s.s[l]) + kLogTwoPi);
      posterior[j][l] = log_likelihood + log_predicted[j][l];
      // The first mode that fails decides the status (ImmEstimator stops there).
      const double mode_outcome =
          pick(s.usable[l] != 0.0, pick(s.finite[l] != 0.0, kOk, kNonFinite), kSingular);
      outcome[l] = pick(outcome[l] != kOk, outcome[l], mode_outcome);
    }
  }

  // The posterior in log space (ImmEstimator::finish_cycle): μ̃_j = exp(ℓ_j − max ℓ),
  // log μ_j = (ℓ_j − max ℓ) − log Σ μ̃, μ_j = μ̃_j / Σ μ̃.
  Lanes top, sum, log_sum, scaled[kMaxLevels], mu[kMaxLevels];
  IMM_LANES top[l] = -std::numeric_limits<double>::infinity();
  for (int j = 0; j < n; ++j) {
    IMM_LANES top[l] = std::max(top[l], posterior[j][l]);
  }
  IMM_LANES sum[l] = 0.0;
  for (int j = 0; j < n; ++j) {
    IMM_LANES {
      posterior[j][l] -= top[l];
      scaled[j][l] = lane_exp(posterior[j][l]);
      sum[l] += scaled[j][l];
    }
  }
  IMM_LANES {
    // A non-finite max ℓ: every likelihood underflowed (or a NaN got through).
    const bool finite_top = std::abs(top[l]) < std::numeric_limits<double>::infinity();
    outcome[l] = pick((outcome[l] == kOk) & !finite_top, kUnderflow, outcome[l]);
    log_sum[l] = lane_log(sum[l]);
  }
  for (int j = 0; j < n; ++j) {
    IMM_LANES {
      mu[j][l] = scaled[j][l] / sum[l];
      posterior[j][l] -= log_sum[l];  // log μ_j
    }
  }
  // The combination (eq. 10–11) of the new estimates.
  Lanes e0, e1, e00, e01, e11;
  lanes::mix<W>(n, mu, next, e0, e1, e00, e01, e11);

  // A track commits when both its lanes (x at an even lane, y after it) succeeded.
  bank::track_codes<W>(outcome, z, code);
  Lanes commit;
  IMM_LANES commit[l] = pick((stepped[l] != 0.0) & (code[l] == kOk), 1.0, 0.0);
  for (int j = 0; j < n; ++j) {
    const double* values[kModeSlots] = {next.x0[j],  next.x1[j],   next.p00[j], next.p01[j],
                                        next.p11[j], posterior[j], scaled[j],   next.previous[j]};
    for (int e = 0; e < kModeSlots; ++e) {
      double* target = st(j, e);
      const double* value = values[e];
      IMM_LANES target[l] = pick(commit[l] != 0.0, value[l], target[l]);
    }
  }
  const double* estimate[5] = {e0, e1, e00, e01, e11};
  for (int e = 0; e < 5; ++e) {
    double* target = combined(e);
    IMM_LANES target[l] = pick(commit[l] != 0.0, estimate[e][l], target[l]);
  }
}

}  // namespace

GaFuzzyTrackBank::GaFuzzyTrackBank(const GaFuzzyImmSpec& spec, std::size_t capacity,
                                   bool wide_blocks)
    : wide_blocks_(wide_blocks) {
  spec.validate();
  modes_ = static_cast<int>(spec.levels.size());
  const Eigen::MatrixXd transition = spec.settings.transition(modes_);
  if (!(transition.array() > 0.0).all()) {
    throw InvalidParameter("settings.transition_stay",
                           "the GA-fuzzy track bank needs every transition probability positive "
                           "(transition_stay below 1 with more than one level)");
  }
  bank::require_capacity(capacity);
  capacity_ = capacity;
  stride_ = static_cast<std::ptrdiff_t>((2 * capacity + kBlock - 1) / kBlock * kBlock);
  const Eigen::VectorXd initial = spec.settings.initial_probabilities(modes_);
  for (int i = 0; i < modes_; ++i) {
    for (int j = 0; j < modes_; ++j) transition_.push_back(transition(i, j));
    initial_log_mu_.push_back(safe_log(initial(i)));
    levels_.emplace_back(spec.levels[static_cast<std::size_t>(i)].table);
  }
  axis_ = lanes::FuzzyAxisConstants(
      spec.settings.sample_period,
      spec.settings.measurement_sigma * spec.settings.measurement_sigma, spec.antecedents);
  state_.assign(static_cast<std::size_t>((modes_ * kModeSlots + 5) * stride_), 0.0);
  scratch_.assign(std::size_t{3} * kBlock, 0.0);
  initialized_.assign(capacity, 0);
}

std::size_t GaFuzzyTrackBank::checked(std::size_t track) const {
  return bank::checked_track(track, capacity_);
}

bool GaFuzzyTrackBank::initialized(std::size_t track) const {
  return initialized_[checked(track)] != 0;
}

void GaFuzzyTrackBank::initialize(std::size_t track, const GaussianState<4>& state) {
  const auto t = static_cast<std::ptrdiff_t>(checked(track));
  const double top = *std::max_element(initial_log_mu_.begin(), initial_log_mu_.end());
  for (int axis = 0; axis < 2; ++axis) {
    const std::ptrdiff_t lane = 2 * t + axis;
    const std::array<double, 5> values = bank::axis_entries(state, axis);
    // ImmEstimator::initialize: every mode takes the state, then the combination with
    // μ_j = exp(log μ_j(0)).
    double sum[5] = {};
    for (int j = 0; j < modes_; ++j) {
      const double log_mu = initial_log_mu_[static_cast<std::size_t>(j)];
      for (int e = 0; e < 5; ++e) slot(j * kModeSlots + e)[lane] = values[e];
      slot(j * kModeSlots + kLogMu)[lane] = log_mu;
      slot(j * kModeSlots + kScaledMu)[lane] = std::exp(log_mu - top);
      slot(j * kModeSlots + kPrevious)[lane] = 0.0;
      const double mu = std::exp(log_mu);
      sum[0] += mu * values[0];
      sum[1] += mu * values[1];
    }
    for (int j = 0; j < modes_; ++j) {
      const double mu = std::exp(initial_log_mu_[static_cast<std::size_t>(j)]);
      if (mu == 0.0) continue;
      const double d0 = values[0] - sum[0], d1 = values[1] - sum[1];
      sum[2] += mu * (values[2] + d0 * d0);
      sum[3] += mu * (values[3] + d0 * d1);
      sum[4] += mu * (values[4] + d1 * d1);
    }
    for (int e = 0; e < 5; ++e) slot(modes_ * kModeSlots + e)[lane] = sum[e];
  }
  initialized_[static_cast<std::size_t>(t)] = 1;
}

void GaFuzzyTrackBank::step(std::span<const Eigen::Vector2d> plots, std::span<StepStatus> status) {
  bank::check_step("GaFuzzyTrackBank", plots.size(), status.size(), initialized_);
  const BankConstants constants{modes_, transition_.data(), &axis_, levels_.data()};
  bank::step_blocks<kBlock>(
      plots, status, wide_blocks_, scratch_.data(),
      [&](auto width, std::size_t first, const double* z, const double* stepped, double* code) {
        step_block<decltype(width)::value>(constants, state_.data() + first, stride_, z, stepped,
                                           code);
      });
}

GaussianState<4> GaFuzzyTrackBank::estimate(std::size_t track) const {
  return bank::two_axis_estimate(
      static_cast<std::ptrdiff_t>(checked(track)),
      [&](int e, std::ptrdiff_t lane) { return slot(modes_ * kModeSlots + e)[lane]; });
}

ModeVector GaFuzzyTrackBank::mode_probabilities(std::size_t track) const {
  const auto t = static_cast<std::ptrdiff_t>(checked(track));
  ModeVector mu(2 * modes_);
  for (int axis = 0; axis < 2; ++axis) {
    for (int j = 0; j < modes_; ++j)
      mu(axis * modes_ + j) = std::exp(slot(j * kModeSlots + kLogMu)[2 * t + axis]);
  }
  return mu;
}

}  // namespace imm
