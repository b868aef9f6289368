// SPDX-License-Identifier: Apache-2.0
#include "track_bank_kernel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>
#include <utility>

#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"

namespace imm::bank {
namespace {

// Σ_i w_i N(mean_i, P_i) collapsed to one Gaussian per lane (eq. 4–5 and 10–11): component i's
// weights at weights + i·kB, its entries at mode(i, e); the result into out (kEntries slots).
template <class Mode>
[[gnu::always_inline]] inline void moment_match(int components, int lanes, const double* weights,
                                                Mode&& mode, double* out) {
  for (int e = 0; e < kEntries; ++e) std::fill_n(out + e * kB, lanes, 0.0);
  for (int i = 0; i < components; ++i) {
    const double* __restrict w = weights + i * kB;
    for (int a = 0; a < kN; ++a) {
      const double* __restrict mean = mode(i, a);
      double* __restrict sum = out + a * kB;
      for (int l = 0; l < lanes; ++l) sum[l] += w[l] * mean[l];
    }
  }
  for (int i = 0; i < components; ++i) {
    const double* __restrict w = weights + i * kB;
    for (int a = 0; a < kN; ++a) {
      for (int c = a; c < kN; ++c) {
        const double* __restrict ma = mode(i, a);
        const double* __restrict mc = mode(i, c);
        const double* __restrict xa = out + a * kB;
        const double* __restrict xc = out + c * kB;
        const double* __restrict p = mode(i, kN + sym(a, c));
        double* __restrict sum = out + (kN + sym(a, c)) * kB;
        for (int l = 0; l < lanes; ++l) sum[l] += w[l] * (p[l] + (ma[l] - xa[l]) * (mc[l] - xc[l]));
      }
    }
  }
}

}  // namespace

[[gnu::flatten]] IMM_VECTOR_CLONES void step_tracks(const Block& b) {
  const int n = b.modes;
  const int lanes = b.lanes;
  const ScratchLayout layout(n);
  auto st = [&](int j, int entry) { return b.state + (j * kModeSlots + entry) * b.stride; };
  auto combined = [&](int entry) { return b.state + (n * kModeSlots + entry) * b.stride; };
  auto sc = [&](int slot) { return b.scratch + slot * kB; };

  // A (vector): predicted mode probabilities c̃_j = Σ_i p_ij μ̃_i with μ̃ = μ / max μ (as
  // ImmEstimator does) and mixing weights μ_ij = p_ij μ̃_i / c̃_j (eq. 6).
  for (int j = 0; j < n; ++j) {
    double* __restrict c = sc(layout.predicted + j);
    std::fill_n(c, lanes, 0.0);
    for (int i = 0; i < n; ++i) {
      const double p = b.transition[i * n + j];
      const double* __restrict mu = st(i, kScaledMu);
      for (int l = 0; l < lanes; ++l) c[l] += p * mu[l];
    }
    for (int i = 0; i < n; ++i) {
      const double p = b.transition[i * n + j];
      const double* __restrict mu = st(i, kScaledMu);
      double* __restrict w = sc(layout.weights + j * n + i);
      for (int l = 0; l < lanes; ++l) w[l] = p * mu[l] / c[l];  // NaN where c̃_j = 0: fixed below
    }
  }

  // A' (scalar): usable plots; log c_j; where c̃_j underflowed (zero transition entries) the exact
  // log-sum-exp and weights from it.
  for (int l = 0; l < lanes; ++l) {
    const double zx = b.plots[l].x(), zy = b.plots[l].y();
    const bool usable = limits::usable_measurement(zx) && limits::usable_measurement(zy);
    sc(layout.zx)[l] = usable ? zx : 0.0;
    sc(layout.zy)[l] = usable ? zy : 0.0;
    sc(layout.ok)[l] = usable ? 1.0 : 0.0;
    double shift = -std::numeric_limits<double>::infinity();
    for (int i = 0; i < n; ++i) shift = std::max(shift, st(i, kLogMu)[l]);
    for (int j = 0; j < n; ++j) {
      const double c = sc(layout.predicted + j)[l];
      if (c > 0.0) {
        sc(layout.log_predicted + j)[l] = std::log(c) + shift;
        continue;
      }
      double* w = sc(layout.weights + j * n);
      double largest = -std::numeric_limits<double>::infinity();
      for (int i = 0; i < n; ++i)
        largest = std::max(largest, b.log_transition[i * n + j] + st(i, kLogMu)[l]);
      double log_c = largest;
      if (std::isfinite(largest)) {
        double sum = 0.0;
        for (int i = 0; i < n; ++i)
          sum += std::exp(b.log_transition[i * n + j] + st(i, kLogMu)[l] - largest);
        // sum ≥ 1: the largest term is exp(0).
        log_c = largest + std::log(sum);  // cppcheck-suppress invalidFunctionArg
      }
      sc(layout.log_predicted + j)[l] = log_c;
      for (int i = 0; i < n; ++i) {
        // Unreachable mode: it keeps its own estimate as the initial condition.
        w[i * kB + l] = !std::isfinite(log_c)
                            ? (i == j ? 1.0 : 0.0)
                            : std::exp(b.log_transition[i * n + j] + st(i, kLogMu)[l] - log_c);
      }
    }
  }

  // B (vector): mixed initial conditions (eq. 4–5) into `mixed`.
  for (int j = 0; j < n; ++j) {
    moment_match(n, lanes, sc(layout.weights + j * n), st, sc(layout.mixed + j * kEntries));
  }

  // C (vector): prediction x⁻ = F x, P⁻ = F P Fᵀ + Q with F = [[1, T], [0, 1]] per axis.
  const double T = b.period;
  for (int j = 0; j < n; ++j) {
    double* __restrict x = sc(layout.mixed + j * kEntries);
    const double* q = b.noise + static_cast<std::ptrdiff_t>(j) * kTriangle;
    for (int l = 0; l < lanes; ++l) {
      cv_position::predict([&](int e) -> double& { return x[e * kB + l]; }, T, q);
    }
  }

  // D (vector): Joseph-form update with H selecting [x, y] (cv_position_algebra.hpp). The checks
  // of its outcome run in phase E: a comparison here would keep this loop scalar.
  const double r00 = b.r00, r01 = b.r01, r11 = b.r11;
  const double* __restrict zx = sc(layout.zx);
  const double* __restrict zy = sc(layout.zy);
  for (int j = 0; j < n; ++j) {
    const double* __restrict x = sc(layout.mixed + j * kEntries);
    double* __restrict u = sc(layout.updated + j * kEntries);
    double* __restrict det_out = sc(layout.determinant + j);
    double* __restrict maha_out = sc(layout.mahalanobis + j);
    double* __restrict s00_out = sc(layout.s00 + j);
    double* __restrict threshold_out = sc(layout.threshold + j);
    double* __restrict finite_out = sc(layout.finite + j);
    for (int l = 0; l < lanes; ++l) {
      const cv_position::UpdateOutcome o = cv_position::update(
          [&](int e) { return x[e * kB + l]; }, [&](int e) -> double& { return u[e * kB + l]; },
          zx[l], zy[l], r00, r01, r11);
      det_out[l] = o.det;
      maha_out[l] = o.mahalanobis;
      s00_out[l] = o.s00;
      threshold_out[l] = o.threshold;
      finite_out[l] = o.finite;
    }
  }

  // E (scalar): statuses and the posterior mode probabilities in log space (eq. 8–9).
  for (int l = 0; l < lanes; ++l) {
    double* ok = sc(layout.ok) + l;
    if (*ok == 0.0) {
      b.status[l] = StepStatus::kInvalidMeasurement;
      continue;
    }
    StepStatus outcome = StepStatus::kOk;
    for (int j = 0; j < n && outcome == StepStatus::kOk; ++j) {
      // S positive definite (Sylvester, with kalman_filter.hpp's relative guard), then finite.
      const double s00 = sc(layout.s00 + j)[l];
      if (!(s00 > 0.0) || !(sc(layout.determinant + j)[l] > sc(layout.threshold + j)[l])) {
        outcome = StepStatus::kSingularInnovation;
      } else if (sc(layout.finite + j)[l] != 0.0) {
        outcome = StepStatus::kNonFiniteResult;
      }
    }
    double shift = -std::numeric_limits<double>::infinity();
    double* posterior = sc(layout.posterior) + l;
    if (outcome == StepStatus::kOk) {
      for (int j = 0; j < n; ++j) {
        const double log_likelihood =
            -0.5 * (sc(layout.mahalanobis + j)[l] + std::log(sc(layout.determinant + j)[l]) +
                    2 * kLogTwoPi);
        posterior[j * kB] = log_likelihood + sc(layout.log_predicted + j)[l];
        shift = std::max(shift, posterior[j * kB]);
      }
      if (!std::isfinite(shift)) outcome = StepStatus::kProbabilityUnderflow;
    }
    b.status[l] = outcome;
    if (outcome != StepStatus::kOk) {
      *ok = 0.0;
      continue;
    }
    double sum = 0.0;
    for (int j = 0; j < n; ++j) {
      const double centered = posterior[j * kB] - shift;
      sc(layout.new_log_mu + j)[l] = centered;
      const double scaled = std::exp(centered);
      sc(layout.new_scaled_mu + j)[l] = scaled;
      sum += scaled;
    }
    // log μ_j = (ℓ_j − shift) − log Σ, in that order (see ImmEstimator::finish_cycle).
    const double log_sum = std::log(sum);  // cppcheck-suppress invalidFunctionArg
    for (int j = 0; j < n; ++j) {
      sc(layout.new_log_mu + j)[l] -= log_sum;
      posterior[j * kB] = sc(layout.new_scaled_mu + j)[l] / sum;
    }
  }

  // F (vector): commit the tracks that succeeded and combine (eq. 10–11).
  const double* __restrict ok = sc(layout.ok);
  for (int j = 0; j < n; ++j) {
    for (int e = 0; e < kEntries; ++e) {
      double* __restrict current = st(j, e);
      const double* __restrict pending = sc(layout.updated + j * kEntries + e);
      for (int l = 0; l < lanes; ++l) current[l] = ok[l] != 0.0 ? pending[l] : current[l];
    }
    double* __restrict log_mu = st(j, kLogMu);
    double* __restrict scaled = st(j, kScaledMu);
    const double* __restrict new_log = sc(layout.new_log_mu + j);
    const double* __restrict new_scaled = sc(layout.new_scaled_mu + j);
    for (int l = 0; l < lanes; ++l) {
      log_mu[l] = ok[l] != 0.0 ? new_log[l] : log_mu[l];
      scaled[l] = ok[l] != 0.0 ? new_scaled[l] : scaled[l];
    }
  }
  // The combination, computed for every lane (scratch: mode 0's mixed slots, no longer needed)
  // and stored for the committed ones.
  double* out = sc(layout.mixed);
  moment_match(n, lanes, sc(layout.posterior), st, out);
  for (int e = 0; e < kEntries; ++e) {
    double* __restrict target = combined(e);
    const double* __restrict value = out + e * kB;
    for (int l = 0; l < lanes; ++l) target[l] = ok[l] != 0.0 ? value[l] : target[l];
  }
}

}  // namespace imm::bank
