// SPDX-License-Identifier: Apache-2.0
#include "track_bank_kernel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>
#include <utility>

#include "imm/math/lane_math.hpp"
#include "imm/math/log_sum_exp.hpp"

// Before a lane loop whose slots are disjoint: GCC would otherwise version it with a run-time
// alias test per pair of pointers and, past ten of them, leave it scalar.
#if defined(__GNUC__) && !defined(__clang__)
#define IMM_LANES_INDEPENDENT _Pragma("GCC ivdep")
#else
#define IMM_LANES_INDEPENDENT
#endif

namespace imm::bank {
namespace {

// Σ_i w_i N(mean_i, P_i) collapsed to one Gaussian per lane (eq. 4–5 and 10–11): component i's
// weights at weights + i·kB, its entries at mode(i, e); the result into out (kEntries slots).
// Each output entry is summed over the components in a register, i = 0, 1, … (the order of the
// one-track IMM's sum), and stored once.
template <int N, class Mode>
[[gnu::always_inline]] inline void moment_match_of(int lanes, const double* weights, Mode&& mode,
                                                   double* out) {
  const double* w[N];
  for (int i = 0; i < N; ++i) w[i] = weights + i * kB;
  for (int a = 0; a < kN; ++a) {
    const double* m[N];
    for (int i = 0; i < N; ++i) m[i] = mode(i, a);
    double* __restrict sum = out + a * kB;
    IMM_LANES_INDEPENDENT
    for (int l = 0; l < lanes; ++l) {
      double s = 0.0;
      for (int i = 0; i < N; ++i) s += w[i][l] * m[i][l];
      sum[l] = s;
    }
  }
  for (int a = 0; a < kN; ++a) {
    for (int c = a; c < kN; ++c) {
      const double* ma[N];
      const double* mc[N];
      const double* p[N];
      for (int i = 0; i < N; ++i) {
        ma[i] = mode(i, a);
        mc[i] = mode(i, c);
        p[i] = mode(i, kN + sym(a, c));
      }
      const double* __restrict xa = out + a * kB;
      const double* __restrict xc = out + c * kB;
      double* __restrict sum = out + (kN + sym(a, c)) * kB;
      IMM_LANES_INDEPENDENT
      for (int l = 0; l < lanes; ++l) {
        double s = 0.0;
        for (int i = 0; i < N; ++i)
          s += w[i][l] * (p[i][l] + (ma[i][l] - xa[l]) * (mc[i][l] - xc[l]));
        sum[l] = s;
      }
    }
  }
}

// moment_match_of for any number of components (the same sums, in the same order).
template <class Mode>
[[gnu::always_inline]] inline void moment_match(int components, int lanes, const double* weights,
                                                Mode&& mode, double* out) {
  switch (components) {
    case 1:
      return moment_match_of<1>(lanes, weights, mode, out);
    case 2:
      return moment_match_of<2>(lanes, weights, mode, out);
    case 3:
      return moment_match_of<3>(lanes, weights, mode, out);
    case 4:
      return moment_match_of<4>(lanes, weights, mode, out);
    default:
      break;
  }
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

  // A' (vector): log c_j = log c̃_j + max_i log μ_i, by lane_log (within 2 ulp of libm's log).
  double* __restrict shift = sc(layout.shift);
  std::fill_n(shift, lanes, -std::numeric_limits<double>::infinity());
  for (int i = 0; i < n; ++i) {
    const double* __restrict log_mu = st(i, kLogMu);
    for (int l = 0; l < lanes; ++l) shift[l] = std::max(shift[l], log_mu[l]);
  }
  for (int j = 0; j < n; ++j) {
    const double* __restrict c = sc(layout.predicted + j);
    double* __restrict log_c = sc(layout.log_predicted + j);
    for (int l = 0; l < lanes; ++l) log_c[l] = lane_log(c[l]) + shift[l];
  }

  // A'' (scalar, no library call on the common path): usable plots; where c̃_j underflowed (zero
  // transition entries) the exact log-sum-exp and weights from it.
  for (int l = 0; l < lanes; ++l) {
    const double zx = b.plots[l].x(), zy = b.plots[l].y();
    const bool usable = limits::usable_measurement(zx) && limits::usable_measurement(zy);
    sc(layout.zx)[l] = usable ? zx : 0.0;
    sc(layout.zy)[l] = usable ? zy : 0.0;
    sc(layout.ok)[l] = usable ? 1.0 : 0.0;
    for (int j = 0; j < n; ++j) {
      if (sc(layout.predicted + j)[l] > 0.0) continue;
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
    IMM_LANES_INDEPENDENT
    for (int l = 0; l < lanes; ++l) {
      cv_position::predict([x, l](int e) -> double& { return x[e * kB + l]; }, T, q);
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
    IMM_LANES_INDEPENDENT
    for (int l = 0; l < lanes; ++l) {
      const cv_position::UpdateOutcome o = cv_position::update(
          [x, l](int e) { return x[e * kB + l]; },
          [u, l](int e) -> double& { return u[e * kB + l]; }, zx[l], zy[l], r00, r01, r11);
      det_out[l] = o.det;
      maha_out[l] = o.mahalanobis;
      s00_out[l] = o.s00;
      threshold_out[l] = o.threshold;
      finite_out[l] = o.finite;
    }
  }

  // E (scalar, comparisons only): statuses of the update.
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
    b.status[l] = outcome;
    if (outcome != StepStatus::kOk) *ok = 0.0;
  }

  // E' (vector): the posterior mode probabilities in log space (eq. 8–9) for every lane, by
  // lane_log and lane_exp; a lane that failed computes them too and drops them in phase F.
  std::fill_n(shift, lanes, -std::numeric_limits<double>::infinity());
  for (int j = 0; j < n; ++j) {
    const double* __restrict maha = sc(layout.mahalanobis + j);
    const double* __restrict det = sc(layout.determinant + j);
    const double* __restrict log_c = sc(layout.log_predicted + j);
    double* __restrict posterior = sc(layout.posterior + j);
    for (int l = 0; l < lanes; ++l) {
      posterior[l] = -0.5 * (maha[l] + lane_log(det[l]) + 2 * kLogTwoPi) + log_c[l];
      shift[l] = std::max(shift[l], posterior[l]);
    }
  }
  // A lane whose every likelihood underflowed keeps its state.
  for (int l = 0; l < lanes; ++l) {
    if (sc(layout.ok)[l] != 0.0 && !std::isfinite(shift[l])) {
      b.status[l] = StepStatus::kProbabilityUnderflow;
      sc(layout.ok)[l] = 0.0;
    }
  }
  double* __restrict sum = sc(layout.zx);  // the plots are no longer needed
  std::fill_n(sum, lanes, 0.0);
  for (int j = 0; j < n; ++j) {
    const double* __restrict posterior = sc(layout.posterior + j);
    double* __restrict centered = sc(layout.new_log_mu + j);
    double* __restrict scaled = sc(layout.new_scaled_mu + j);
    for (int l = 0; l < lanes; ++l) {
      centered[l] = posterior[l] - shift[l];
      scaled[l] = lane_exp(centered[l]);
      sum[l] += scaled[l];
    }
  }
  // log μ_j = (ℓ_j − shift) − log Σ, in that order (see ImmEstimator::finish_cycle).
  double* __restrict log_sum = shift;
  for (int l = 0; l < lanes; ++l) log_sum[l] = lane_log(sum[l]);
  for (int j = 0; j < n; ++j) {
    double* __restrict new_log = sc(layout.new_log_mu + j);
    const double* __restrict scaled = sc(layout.new_scaled_mu + j);
    double* __restrict posterior = sc(layout.posterior + j);
    for (int l = 0; l < lanes; ++l) {
      new_log[l] -= log_sum[l];
      posterior[l] = scaled[l] / sum[l];
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
