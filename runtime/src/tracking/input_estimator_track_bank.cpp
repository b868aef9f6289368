// SPDX-License-Identifier: Apache-2.0
// The input-estimator bank: axis filters as lanes, blocks of kBlock lanes stepped in vector loops
// (see the header). The order of operations follows MlpInputEstimatorFilter::step: the primary
// KF with û(k − 1), the feature KF, its windows, the network, the sign, the commit.
#include "imm/tracking/input_estimator_track_bank.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "axis_lane_bank.hpp"
#include "bank_checks.hpp"
#include "imm/core/invalid_parameter.hpp"
#include "imm/core/physical_limits.hpp"
#include "imm/estimation/cv_axis_lanes.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/models/motion/constant_velocity.hpp"

namespace imm {
namespace {

constexpr int kWindow = InnovationFeatures::kWindow;
// State slots: the primary KF, û, the feature KF, ino(k − i) for i = 0 … 10 (newest first), the
// feature KF's last ten ν in ring order and the ring's head.
constexpr int kPrimary = 0, kInput = 5, kCv = 6, kIno = 11, kNu = kIno + kWindow + 1,
              kHead = kNu + kWindow, kSlots = kHead + 1;
using bank::kNonFinite, bank::kOk, bank::kSingular;

struct BankConstants {
  double T, R, g0, g1;
  double qp00, qp01, qp11;  // the primary KF's Q (with σ_û² G Gᵀ)
  double qc00, qc01, qc11;  // the feature KF's Q
  double mean0, mean1, scale0, scale1, output_scale, output_bias;
  bool innovation_sign;
  int layers;
  const int* shape;       // per layer: outputs, inputs, sigmoid
  const double* network;  // per layer: weights row-major, then the biases
};

// One predicted-and-updated axis KF per lane, its outcome code and ν, S.
struct AxisStep {
  lanes::AxisEstimate e;
  double nu, s, code;
};

[[gnu::always_inline]] inline AxisStep kf_step(double T, double R, const lanes::AxisEstimate& from,
                                               double q00, double q01, double q11, double b0,
                                               double b1, double z) {
  lanes::AxisEstimate p = lanes::cv_predict(T, from);
  p.x0 += b0;
  p.x1 += b1;
  p.p00 += q00;
  p.p01 += q01;
  p.p11 += q11;
  const double nu = z - p.x0;
  double s, s_inverse;
  const lanes::AxisEstimate e = lanes::position_update(p, R, nu, s, s_inverse);
  const bool usable = (s > 0.0) & (s < std::numeric_limits<double>::infinity());
  const bool finite = std::isfinite(e.x0 + e.x1 + e.p00 + e.p01 + e.p11);
  return {e, nu, s, pick(usable, pick(finite, kOk, kNonFinite), kSingular)};
}

// One scan of one block's W lanes. `state` points at the block's first lane of slot 0; `z` the
// lanes' plots (NaN: unusable); `stepped` 1 for a lane to step; `code` receives each lane's
// outcome; `work` holds two layers' activations.
template <int W>
[[gnu::flatten]] IMM_VECTOR_CLONES void step_block(const BankConstants& b, double* state,
                                                   std::ptrdiff_t stride, const double* z,
                                                   const double* stepped, double* code,
                                                   double* work, int widest) {
  auto st = [&](int entry) { return state + entry * stride; };
  double primary[5][W], cv[5][W], nu[W], outcome[W], nu_sum[W], head[W], ino[W], x[2][W];
  IMM_LANES {
    const double u = st(kInput)[l];
    const AxisStep p = kf_step(b.T, b.R,
                               {st(kPrimary)[l], st(kPrimary + 1)[l], st(kPrimary + 2)[l],
                                st(kPrimary + 3)[l], st(kPrimary + 4)[l]},
                               b.qp00, b.qp01, b.qp11, b.g0 * u, b.g1 * u, z[l]);
    const AxisStep c = kf_step(
        b.T, b.R, {st(kCv)[l], st(kCv + 1)[l], st(kCv + 2)[l], st(kCv + 3)[l], st(kCv + 4)[l]},
        b.qc00, b.qc01, b.qc11, 0.0, 0.0, z[l]);
    const double values[2][5] = {{p.e.x0, p.e.x1, p.e.p00, p.e.p01, p.e.p11},
                                 {c.e.x0, c.e.x1, c.e.p00, c.e.p01, c.e.p11}};
    for (int e = 0; e < 5; ++e) {
      primary[e][l] = values[0][e];
      cv[e][l] = values[1][e];
    }
    outcome[l] = pick(p.code != kOk, p.code, c.code);
    ino[l] = c.nu * c.nu / c.s;
    nu[l] = c.nu;
    // sum(k) = 0.1 Σ ino(k − i), i < 10, newest first; diff(k) = ino(k) − ino(k − 10).
    double sum = 0.0 + ino[l];
    for (int i = 0; i + 1 < kWindow; ++i) sum += st(kIno + i)[l];
    x[0][l] = (0.1 * sum - b.mean0) / b.scale0;
    x[1][l] = (ino[l] - st(kIno + kWindow - 1)[l] - b.mean1) / b.scale1;
    // The ν ring: the next head takes ν(k); the sum in ring order.
    const double next = st(kHead)[l] + 1.0;
    head[l] = pick(next >= kWindow, 0.0, next);
    double ring_sum = 0.0;
    for (int i = 0; i < kWindow; ++i) ring_sum += pick(head[l] == i, c.nu, st(kNu + i)[l]);
    nu_sum[l] = ring_sum;
  }
  // The network, layer by layer: a = f(W x + b), the sums input by input.
  const double* layer = b.network;
  const double* in = x[0];
  for (std::ptrdiff_t k = 0; k < b.layers; ++k) {
    const std::ptrdiff_t outputs = b.shape[3 * k], inputs = b.shape[3 * k + 1];
    const bool sigmoid = b.shape[3 * k + 2] != 0;
    double* out = work + (k % 2) * widest * W;
    const double* bias = layer + outputs * inputs;
    for (std::ptrdiff_t r = 0; r < outputs; ++r) {
      const double* weights = layer + r * inputs;
      double sum[W];
      IMM_LANES sum[l] = 0.0;
      for (std::ptrdiff_t c = 0; c < inputs; ++c) {
        IMM_LANES sum[l] += weights[c] * in[c * W + l];
      }
      IMM_LANES {
        const double a = sum[l] + bias[r];
        out[r * W + l] = pick(sigmoid, 1.0 / (1.0 + lane_exp(-a)), a);
      }
    }
    in = out;
    layer = bias + outputs;
  }
  // û(k): the scaled output less the bias, clipped at 0, signed; then the track's commit.
  bank::track_codes<W>(outcome, z, code);
  IMM_LANES {
    const double raw = b.output_scale * in[l] - b.output_bias;
    const double magnitude = pick(0.0 < raw, raw, 0.0);
    const double u = pick(b.innovation_sign & (nu_sum[l] < 0.0), -magnitude, magnitude);
    const bool commit = (stepped[l] != 0.0) & (code[l] == kOk);
    for (int e = 0; e < 5; ++e) {
      st(kPrimary + e)[l] = pick(commit, primary[e][l], st(kPrimary + e)[l]);
      st(kCv + e)[l] = pick(commit, cv[e][l], st(kCv + e)[l]);
    }
    st(kInput)[l] = pick(commit, u, st(kInput)[l]);
    for (int i = kWindow; i > 0; --i) {
      st(kIno + i)[l] = pick(commit, st(kIno + i - 1)[l], st(kIno + i)[l]);
    }
    st(kIno)[l] = pick(commit, ino[l], st(kIno)[l]);
    for (int i = 0; i < kWindow; ++i) {
      st(kNu + i)[l] = pick(commit & (head[l] == i), nu[l], st(kNu + i)[l]);
    }
    st(kHead)[l] = pick(commit, head[l], st(kHead)[l]);
  }
}

}  // namespace

InputEstimatorTrackBank::InputEstimatorTrackBank(const MlpInputEstimatorModel& model,
                                                 std::size_t capacity, bool wide_blocks)
    : model_(model), wide_blocks_(wide_blocks) {
  // The one-track filter's checks, with its wording.
  const MlpInputEstimatorFilter check(model, model.settings);
  (void)check;
  allocate(capacity, 2, kBlock, kSlots);
  for (const MlpLayer& layer : model.network.layers()) {
    const auto outputs = static_cast<int>(layer.weights.rows());
    const auto inputs = static_cast<int>(layer.weights.cols());
    shape_.insert(shape_.end(), {outputs, inputs, layer.activation == Activation::kSigmoid});
    for (int r = 0; r < outputs; ++r) {
      for (int c = 0; c < inputs; ++c) network_.push_back(layer.weights(r, c));
    }
    network_.insert(network_.end(), layer.bias.data(), layer.bias.data() + outputs);
    widest_ = std::max({widest_, outputs, inputs});
  }
  scratch_.assign((3 + 2 * static_cast<std::size_t>(widest_)) * kBlock, 0.0);
}

void InputEstimatorTrackBank::initialize(std::size_t track, const GaussianState<4>& state) {
  const std::ptrdiff_t t = checked(track);
  for (int axis = 0; axis < 2; ++axis) {
    const std::ptrdiff_t lane = 2 * t + axis;
    const std::array<double, 5> values = bank::axis_entries(state, axis);
    for (int e = 0; e < 5; ++e) slot(kPrimary + e)[lane] = slot(kCv + e)[lane] = values[e];
    slot(kInput)[lane] = 0.0;
    for (int i = 0; i <= kWindow; ++i) slot(kIno + i)[lane] = InnovationFeatures::kPad;
    for (int i = 0; i < kWindow; ++i) slot(kNu + i)[lane] = 0.0;
    slot(kHead)[lane] = 0.0;
  }
  mark_initialized(t);
}

void InputEstimatorTrackBank::step(std::span<const Eigen::Vector2d> plots,
                                   std::span<StepStatus> status) {
  check_step("InputEstimatorTrackBank", plots.size(), status.size());
  const CvKfSettings& s = model_.settings;
  const LinearMotionModel<2> motion = constant_velocity<1>(s.sample_period, s.process_noise);
  const Vector<2> G = cv_axis_input_gain(s.sample_period);
  SquareMatrix<2> primary_noise = motion.process_noise;
  primary_noise.noalias() += model_.input_variance * G * G.transpose();
  const BankConstants b{s.sample_period,
                        s.measurement_variance,
                        G(0),
                        G(1),
                        primary_noise(0, 0),
                        primary_noise(0, 1),
                        primary_noise(1, 1),
                        motion.process_noise(0, 0),
                        motion.process_noise(0, 1),
                        motion.process_noise(1, 1),
                        model_.input_mean(0),
                        model_.input_mean(1),
                        model_.input_scale(0),
                        model_.input_scale(1),
                        model_.network.output_scale(),
                        model_.output_bias,
                        model_.sign == InputSign::kInnovation,
                        static_cast<int>(model_.network.layers().size()),
                        shape_.data(),
                        network_.data()};
  double* work = scratch_.data() + std::ptrdiff_t{3} * kBlock;
  bank::step_blocks<kBlock>(
      plots, status, wide_blocks_, scratch_.data(),
      [&](auto width, std::size_t first, const double* z, const double* stepped, double* code) {
        step_block<decltype(width)::value>(b, slot(0) + first, stride(), z, stepped, code, work,
                                           widest_);
      });
}

GaussianState<4> InputEstimatorTrackBank::estimate(std::size_t track) const {
  return bank::two_axis_estimate(
      checked(track), [&](int e, std::ptrdiff_t lane) { return slot(kPrimary + e)[lane]; });
}

Eigen::Vector2d InputEstimatorTrackBank::acceleration(std::size_t track) const {
  const std::ptrdiff_t t = checked(track);
  return {slot(kInput)[2 * t], slot(kInput)[2 * t + 1]};
}

ModeVector InputEstimatorTrackBank::mode_probabilities(std::size_t track) const {
  (void)checked(track);
  return ModeVector::Ones(2);
}

}  // namespace imm
