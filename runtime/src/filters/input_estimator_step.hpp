// SPDX-License-Identifier: Apache-2.0
#pragma once
// One scan of the neural input-estimation filter (mlp_input_estimator.hpp), written once for W
// axis filters stored structure of arrays: MlpInputEstimatorFilter runs it for one (W = 1), the
// InputEstimatorTrackBank for blocks of 8 or 16 lanes, and InnovationFeatureExtractor (the
// trainer's features) runs its feature half. Every statement of the lane loops is plain IEEE
// arithmetic without branches or calls (cv_axis_lanes.hpp for both Kalman filters, lane_exp for
// the sigmoids), so an axis filter gives the same bits alone and in any lane of a block, under
// every instruction set. Not installed.
//
// An axis filter's slots (`stride` apart): the primary KF's estimate [x0, x1, p00, p01, p11], û,
// the feature KF's estimate, ino(k − i) for i = 0 … 10 (newest first), the feature KF's last ten ν
// in ring order and the ring's head.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include "imm/estimation/cv_axis_lanes.hpp"
#include "imm/estimation/gaussian_state.hpp"
#include "imm/filters/mlp_input_estimator.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/models/motion/constant_velocity.hpp"
#include "tracking/axis_lane_bank.hpp"

namespace imm::input_estimator {

inline constexpr int kWindow = InnovationFeatures::kWindow;
inline constexpr int kPrimary = 0, kInput = 5, kCv = 6, kIno = 11, kNu = kIno + kWindow + 1,
                     kHead = kNu + kWindow, kSlots = kHead + 1;
static_assert(kSlots == kScanSlots);
using bank::kBadPlot, bank::kNonFinite, bank::kOk, bank::kSingular;

// The feature KF's constants (FeatureConstants, mlp_input_estimator.hpp) of CvKfSettings.
inline FeatureConstants feature_constants(const CvKfSettings& s) {
  const LinearMotionModel<2> motion = constant_velocity<1>(s.sample_period, s.process_noise);
  return {s.sample_period, s.measurement_variance, motion.process_noise(0, 0),
          motion.process_noise(0, 1), motion.process_noise(1, 1)};
}

// One filter's network goes over its units in chunks of this many.
inline constexpr int kUnitChunk = 8;
inline constexpr int chunks(int units) { return (units + kUnitChunk - 1) / kUnitChunk; }

// A model's constants as the scan reads them: the primary KF's G and Q (with σ_û² G Gᵀ), the
// standardization, and the network flattened.
struct Constants {
  FeatureConstants cv;
  double g0 = 0.0, g1 = 0.0;
  double qp00 = 0.0, qp01 = 0.0, qp11 = 0.0;
  double mean0 = 0.0, mean1 = 0.0, scale0 = 1.0, scale1 = 1.0;
  double output_scale = 1.0, output_bias = 0.0;
  bool innovation_sign = false;
  std::vector<int> shape;  // per layer: outputs, inputs, sigmoid
  // Per layer the weights column by column, then the biases, each column padded with zeros to
  // whole chunks of kUnitChunk units (one filter's scan reads a chunk of units at once).
  std::vector<double> columns;
  int widest = 0;  // the most units of a layer (rounded up to whole chunks)

  explicit Constants(const MlpInputEstimatorModel& model)
      : cv(feature_constants(model.settings)),
        mean0(model.input_mean(0)),
        mean1(model.input_mean(1)),
        scale0(model.input_scale(0)),
        scale1(model.input_scale(1)),
        output_scale(model.network.output_scale()),
        output_bias(model.output_bias),
        innovation_sign(model.sign == InputSign::kInnovation) {
    const CvKfSettings& s = model.settings;
    const LinearMotionModel<2> motion = constant_velocity<1>(s.sample_period, s.process_noise);
    const Vector<2> G = cv_axis_input_gain(s.sample_period);
    SquareMatrix<2> noise = motion.process_noise;
    noise.noalias() += model.input_variance * G * G.transpose();
    g0 = G(0);
    g1 = G(1);
    qp00 = noise(0, 0);
    qp01 = noise(0, 1);
    qp11 = noise(1, 1);
    for (const MlpLayer& layer : model.network.layers()) {
      const auto outputs = static_cast<int>(layer.weights.rows());
      const auto inputs = static_cast<int>(layer.weights.cols());
      shape.insert(shape.end(), {outputs, inputs, layer.activation == Activation::kSigmoid});
      const int padded = chunks(outputs) * kUnitChunk;
      for (int c = 0; c < inputs; ++c) {
        for (int r = 0; r < padded; ++r) columns.push_back(r < outputs ? layer.weights(r, c) : 0.0);
      }
      for (int r = 0; r < padded; ++r) columns.push_back(r < outputs ? layer.bias(r) : 0.0);
      widest = std::max({widest, padded, inputs});
    }
  }
  // The layers.
  [[nodiscard]] int layers() const { return static_cast<int>(shape.size() / 3); }
};

// One axis filter's start: both KFs take [x0, x1, p00, p01, p11], û 0, the windows their start
// (ino padded with InnovationFeatures::kPad, ν with 0).
template <class Slot>
void start(Slot&& at, const std::array<double, 5>& values) {
  for (int e = 0; e < 5; ++e) at(kPrimary + e) = at(kCv + e) = values[e];
  at(kInput) = 0.0;
  for (int i = 0; i <= kWindow; ++i) at(kIno + i) = InnovationFeatures::kPad;
  for (int i = 0; i < kWindow; ++i) at(kNu + i) = 0.0;
  at(kHead) = 0.0;
}

// One predicted-and-updated axis KF, its outcome code and ν, S.
struct AxisStep {
  lanes::AxisEstimate e;
  double nu, s, code;
};

// x⁻ = F x + [b0, b1], P⁻ = F P Fᵀ + Q.
[[gnu::always_inline]] inline lanes::AxisEstimate predicted(double T,
                                                            const lanes::AxisEstimate& from,
                                                            double q00, double q01, double q11,
                                                            double b0, double b1) {
  lanes::AxisEstimate p = lanes::cv_predict(T, from);
  p.x0 += b0;
  p.x1 += b1;
  p.p00 += q00;
  p.p01 += q01;
  p.p11 += q11;
  return p;
}

[[gnu::always_inline]] inline AxisStep kf_step(double T, double R, const lanes::AxisEstimate& from,
                                               double q00, double q01, double q11, double b0,
                                               double b1, double z) {
  const lanes::AxisEstimate p = predicted(T, from, q00, q01, q11, b0, b1);
  const double nu = z - p.x0;
  double s, s_inverse;
  const lanes::AxisEstimate e = lanes::position_update(p, R, nu, s, s_inverse);
  const bool usable = (s > 0.0) & (s < std::numeric_limits<double>::infinity());
  const bool finite = std::isfinite(e.x0 + e.x1 + e.p00 + e.p01 + e.p11);
  return {e, nu, s, pick(usable, pick(finite, kOk, kNonFinite), kSingular)};
}

// An estimate's five slots from `first`.
template <class Slot>
[[gnu::always_inline]] inline lanes::AxisEstimate estimate_at(Slot&& at, int first) {
  return {at(first), at(first + 1), at(first + 2), at(first + 3), at(first + 4)};
}

// Writes an estimate into its five slots from `first`.
template <class Slot>
[[gnu::always_inline]] inline void put_estimate(Slot&& at, int first,
                                                const lanes::AxisEstimate& e) {
  const double values[5] = {e.x0, e.x1, e.p00, e.p01, e.p11};
  for (int k = 0; k < 5; ++k) at(first + k) = values[k];
}

// The feature half of a scan (eq. 3–9, 11–14): the feature KF, ino(k) = ν²/S, the raw features
// sum(k) = 0.1 Σ_{i<10} ino(k − i) and diff(k) = ino(k) − ino(k − 10), the ν ring's next head and
// its sum in ring order with ν(k). Nothing is written.
struct FeatureScan {
  AxisStep cv;
  double ino, sum, diff, head, nu_sum;
};
template <class Slot>
[[gnu::always_inline]] inline FeatureScan feature_scan(const FeatureConstants& c, Slot&& at,
                                                       double z) {
  FeatureScan f{};
  f.cv = kf_step(c.T, c.R, estimate_at(at, kCv), c.q00, c.q01, c.q11, 0.0, 0.0, z);
  f.ino = f.cv.nu * f.cv.nu / f.cv.s;
  double sum = 0.0 + f.ino;
  for (int i = 0; i + 1 < kWindow; ++i) sum += at(kIno + i);
  f.sum = 0.1 * sum;
  f.diff = f.ino - at(kIno + kWindow - 1);
  const double next = at(kHead) + 1.0;
  f.head = pick(next >= kWindow, 0.0, next);
  double ring_sum = 0.0;
  for (int i = 0; i < kWindow; ++i) ring_sum += pick(f.head == i, f.cv.nu, at(kNu + i));
  f.nu_sum = ring_sum;
  return f;
}

// The feature half's commit where `commit`: the feature KF (`cv`), the ino shift register, the ν
// ring (ν at `head`).
template <class Slot>
[[gnu::always_inline]] inline void keep_features(Slot&& at, const double (&cv)[5], double ino,
                                                 double head, double nu, bool commit) {
  for (int e = 0; e < 5; ++e) at(kCv + e) = pick(commit, cv[e], at(kCv + e));
  for (int i = kWindow; i > 0; --i) at(kIno + i) = pick(commit, at(kIno + i - 1), at(kIno + i));
  at(kIno) = pick(commit, ino, at(kIno));
  for (int i = 0; i < kWindow; ++i) at(kNu + i) = pick(commit & (head == i), nu, at(kNu + i));
  at(kHead) = pick(commit, head, at(kHead));
}

// The feature KF's prediction alone (a scan without a plot): the windows do not move.
template <class Slot>
[[gnu::always_inline]] inline void coast_features(const FeatureConstants& c, Slot&& at) {
  put_estimate(at, kCv, predicted(c.T, estimate_at(at, kCv), c.q00, c.q01, c.q11, 0.0, 0.0));
}

// The primary KF's prediction with û(k − 1) (eq. 10).
template <class Slot>
[[gnu::always_inline]] inline lanes::AxisEstimate primary_prediction(const Constants& b,
                                                                     Slot&& at) {
  const double u = at(kInput);
  return predicted(b.cv.T, estimate_at(at, kPrimary), b.qp00, b.qp01, b.qp11, b.g0 * u, b.g1 * u);
}

// The primary KF's prediction as a Gaussian: what MlpInputEstimatorFilter::predict() holds for
// candidate plots (it does not depend on the plot) and the bank scores its candidates against.
template <class Slot>
[[nodiscard]] inline GaussianState<2> held_prediction(const Constants& b, Slot&& at) {
  const lanes::AxisEstimate p = primary_prediction(b, at);
  GaussianState<2> held;
  held.mean << p.x0, p.x1;
  held.covariance << p.p00, p.p01, p.p01, p.p11;
  return held;
}

// The network of one lane from its inputs `x` (two): each layer's units a chunk at a time, the
// chunk's sums held in registers over the inputs; every unit's sum from 0 input by input as the
// lanes' loop forms it (so the same bits), its sigmoid by lane_exp. Returns the output (in
// `work`, 2 · widest).
[[gnu::always_inline]] inline const double* network_of_one(const Constants& b, const double* x,
                                                           double* work) {
  constexpr int C = kUnitChunk;
  const double* layer = b.columns.data();
  const double* in = x;
  for (int k = 0; k < b.layers(); ++k) {
    const auto u = static_cast<std::size_t>(k);
    const int inputs = b.shape[3 * u + 1];
    const int padded = chunks(b.shape[3 * u]) * C;
    const bool sigmoid = b.shape[3 * u + 2] != 0;
    double* out = work + static_cast<std::ptrdiff_t>(k % 2) * b.widest;
    const double* bias = layer + static_cast<std::ptrdiff_t>(padded) * inputs;
    for (int first = 0; first < padded; first += C) {
      double sum[C];
      for (int j = 0; j < C; ++j) sum[j] = 0.0;
      for (int c = 0; c < inputs; ++c) {
        const double v = in[c];
        const double* column = layer + static_cast<std::ptrdiff_t>(c) * padded + first;
        for (int j = 0; j < C; ++j) sum[j] += column[j] * v;
      }
      for (int j = 0; j < C; ++j) {
        const double a = sum[j] + bias[first + j];
        out[first + j] = pick(sigmoid, 1.0 / (1.0 + lane_exp(-a)), a);
      }
    }
    in = out;
    layer = bias + padded;
  }
  return in;
}

// What a scan reports of each lane besides its slots (the one-track filter's accessors).
template <int W>
struct ScanReport {
  double nu[W], s[W];  // the primary KF's ν(k) and S(k)
  double raw[W];       // the network's output before the bias and the sign
  double input[2][W];  // the standardized features
  double cv_nu[W];     // the feature KF's ν(k)
};

// One scan of W axis filters. `state` points at the first lane's slot 0; `z` the lanes' plots
// (NaN: unusable); `stepped` 1 for a lane to step; `code` receives each lane's outcome (a pair of
// lanes, x then y, fails as one where kPairedAxes); `work` holds two layers' activations (2 ·
// widest · W). A lane commits where `stepped` and its code is kOk. `report`, where not null,
// receives the lanes' ν, S, features and network output.
template <int W, bool kPairedAxes>
[[gnu::always_inline]] inline void scan(const Constants& b, double* state, std::ptrdiff_t stride,
                                        const double* z, const double* stepped, double* code,
                                        double* work, ScanReport<W>* report) {
  auto st = [&](int entry) { return state + entry * stride; };
  // The lanes' results as arrays per quantity (the loops stay vector loops).
  double primary[5][W], cv[5][W], nu[W], s[W], outcome[W], x[2][W];
  double ino[W], head[W], cv_nu[W], nu_sum[W];
  IMM_LANES {
    auto at = [&](int entry) -> double& { return st(entry)[l]; };
    const AxisStep p = kf_step(b.cv.T, b.cv.R, estimate_at(at, kPrimary), b.qp00, b.qp01, b.qp11,
                               b.g0 * at(kInput), b.g1 * at(kInput), z[l]);
    const FeatureScan f = feature_scan(b.cv, at, z[l]);
    const double values[2][5] = {{p.e.x0, p.e.x1, p.e.p00, p.e.p01, p.e.p11},
                                 {f.cv.e.x0, f.cv.e.x1, f.cv.e.p00, f.cv.e.p01, f.cv.e.p11}};
    for (int e = 0; e < 5; ++e) {
      primary[e][l] = values[0][e];
      cv[e][l] = values[1][e];
    }
    nu[l] = p.nu;
    s[l] = p.s;
    outcome[l] = pick(p.code != kOk, p.code, f.cv.code);
    x[0][l] = (f.sum - b.mean0) / b.scale0;
    x[1][l] = (f.diff - b.mean1) / b.scale1;
    ino[l] = f.ino;
    head[l] = f.head;
    cv_nu[l] = f.cv.nu;
    nu_sum[l] = f.nu_sum;
  }
  // The network, layer by layer: a = f(W x + b), each unit's sum input by input. Over the lanes
  // for a block; for one lane over the units (the weights column by column), the same sums.
  const double* in = x[0];
  if constexpr (W == 1) {
    in = network_of_one(b, in, work);
  } else {
    const double* layer = b.columns.data();
    for (int k = 0; k < b.layers(); ++k) {
      const auto u = static_cast<std::size_t>(k);
      const std::ptrdiff_t outputs = b.shape[3 * u], inputs = b.shape[3 * u + 1];
      const auto padded = static_cast<std::ptrdiff_t>(chunks(b.shape[3 * u])) * kUnitChunk;
      const bool sigmoid = b.shape[3 * u + 2] != 0;
      double* out = work + static_cast<std::ptrdiff_t>(k % 2) * b.widest * W;
      const double* bias = layer + padded * inputs;
      for (std::ptrdiff_t r = 0; r < outputs; ++r) {
        double sum[W];
        IMM_LANES sum[l] = 0.0;
        for (std::ptrdiff_t c = 0; c < inputs; ++c) {
          const double weight = layer[c * padded + r];
          IMM_LANES sum[l] += weight * in[c * W + l];
        }
        IMM_LANES {
          const double a = sum[l] + bias[r];
          out[r * W + l] = pick(sigmoid, 1.0 / (1.0 + lane_exp(-a)), a);
        }
      }
      in = out;
      layer = bias + padded;
    }
  }
  // û(k): the scaled output less the bias, clipped at 0, signed; then the commit.
  if constexpr (kPairedAxes) {
    bank::track_codes<W>(outcome, z, code);
  } else {
    IMM_LANES code[l] = pick(z[l] == z[l], outcome[l], kBadPlot);
  }
  IMM_LANES {
    auto at = [&](int entry) -> double& { return st(entry)[l]; };
    const double raw = b.output_scale * in[l] - b.output_bias;
    const double magnitude = pick(0.0 < raw, raw, 0.0);
    const double u = pick(b.innovation_sign & (nu_sum[l] < 0.0), -magnitude, magnitude);
    const bool commit = (stepped[l] != 0.0) & (code[l] == kOk);
    for (int e = 0; e < 5; ++e) at(kPrimary + e) = pick(commit, primary[e][l], at(kPrimary + e));
    at(kInput) = pick(commit, u, at(kInput));
    const double lane_cv[5] = {cv[0][l], cv[1][l], cv[2][l], cv[3][l], cv[4][l]};
    keep_features(at, lane_cv, ino[l], head[l], cv_nu[l], commit);
  }
  if (report != nullptr) {
    for (int l = 0; l < W; ++l) {
      report->nu[l] = nu[l];
      report->s[l] = s[l];
      report->raw[l] = b.output_scale * in[l];
      report->input[0][l] = x[0][l];
      report->input[1][l] = x[1][l];
      report->cv_nu[l] = cv_nu[l];
    }
  }
}

}  // namespace imm::input_estimator
