// SPDX-License-Identifier: Apache-2.0
#include "imm/models/learned/fuzzy_c_means.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <utility>

#include "imm/core/invalid_parameter.hpp"

// Run-time choice of AVX2 for the membership loop (GCC on x86-64 Linux). Only "avx2": it does not
// enable FMA contraction, so every instruction set computes the same bits.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define IMM_FCM_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define IMM_FCM_CLONES
#endif

namespace imm {
namespace {

// u^m: products for the integer fuzzifiers 2, 3 and 4 (the fits' bounds and the shipped models'),
// the general pow otherwise.
double weight_power(double u, double fuzzifier) {
  if (fuzzifier == 2.0) return u * u;
  if (fuzzifier == 3.0) return u * u * u;
  if (fuzzifier == 4.0) {
    const double u2 = u * u;
    return u2 * u2;
  }
  return std::pow(u, fuzzifier);
}

// ∛r for r in (0, 1] without libm's cbrt (whose frexp and scalbn were most of an FCM-IMM step):
// a first guess from the exponent bits (a third of the exponent, ~3 % off), then three Halley
// steps y ← y (y³ + 2r) / (2y³ + r), each cubing the relative error (3e-2 → 3e-5 → 3e-14 →
// rounding). Plain IEEE arithmetic: the same bits on every machine. Values too small for the
// guess (subnormal ratios) take libm's cbrt.
double cube_root_of_ratio(double r) {
  if (r == 1.0) return 1.0;  // the nearest center's own ratio: one root in three per point
  if (r < 1e-290) return std::cbrt(r);
  std::uint64_t bits = 0;
  std::memcpy(&bits, &r, sizeof bits);
  bits = bits / 3 + 0x2A9F7893782DA1CEULL;
  double y = 0.0;
  std::memcpy(&y, &bits, sizeof y);
  for (int i = 0; i < 3; ++i) {
    const double y3 = y * y * y;
    y = y * (y3 + 2.0 * r) / (2.0 * y3 + r);
  }
  return y;
}

// r^{1/(m − 1)} for r in (0, 1]: the root for the integer fuzzifiers 2 … 5, pow otherwise.
double membership_root(double r, double fuzzifier) {
  if (fuzzifier == 2.0) return r;
  if (fuzzifier == 3.0) return std::sqrt(r);
  if (fuzzifier == 4.0) return cube_root_of_ratio(r);
  if (fuzzifier == 5.0) return std::sqrt(std::sqrt(r));
  return std::pow(r, 1.0 / (fuzzifier - 1.0));
}

ClusterVector clamp(const ClusterVector& v, const ClusterVector& lower,
                    const ClusterVector& upper) {
  ClusterVector out;
  for (int i = 0; i < kFcmClusters; ++i) out(i) = std::clamp(v(i), lower(i), upper(i));
  return out;
}

// The memberships of x into row[0..2]; returns nothing, writes in place.
void memberships_into(double x, const ClusterVector& centers, double fuzzifier, double* row) {
  double d2[kFcmClusters];
  double smallest = std::numeric_limits<double>::infinity();
  int zeros = 0;
  for (int i = 0; i < kFcmClusters; ++i) {
    const double d = x - centers(i);
    d2[i] = d * d;
    if (d2[i] == 0.0) ++zeros;
    smallest = std::min(smallest, d2[i]);
  }
  if (zeros > 0) {
    for (int i = 0; i < kFcmClusters; ++i) row[i] = d2[i] == 0.0 ? 1.0 / zeros : 0.0;
    return;
  }
  // u_i = w_i / Σ w_j with w_i = (d²_min / d²_i)^{1/(m−1)} ∈ (0, 1]: the ratio form of eq. (9)
  // scaled so that nothing overflows however small the distances are.
  double sum = 0.0;
  for (int i = 0; i < kFcmClusters; ++i) {
    row[i] = membership_root(smallest / d2[i], fuzzifier);
    sum += row[i];
  }
  for (int i = 0; i < kFcmClusters; ++i) row[i] /= sum;
}

}  // namespace

void FuzzyCMeansSettings::validate() const {
  // The memberships' exponent 2/(m − 1) overflows as m → 1; beyond m = 100 every membership is
  // 1/c to rounding.
  require(std::isfinite(fuzzifier) && fuzzifier >= 1.01 && fuzzifier <= 100.0, "fuzzifier",
          "must be in [1.01, 100]");
  require(std::isfinite(tolerance) && tolerance >= 1e-15 && tolerance <= 1.0, "tolerance",
          "must be in [1e-15, 1]");
  if (max_iterations < 1 || max_iterations > 100000) {
    throw InvalidParameter("max_iterations", "must be in [1, 100000]");
  }
}

ClusterVector fcm_memberships(double x, const ClusterVector& centers, double fuzzifier) {
  ClusterVector u;
  memberships_into(x, centers, fuzzifier, u.data());
  return u;
}

namespace {

// New memberships of every point for centers v (m = 2), the old ones replaced; returns max |ΔU|.
// The same operations as memberships_into, written without branches so that the compiler
// vectorizes the loop; a point on a center (0/0 below) is redone by memberships_into.
IMM_FCM_CLONES
double update_memberships_m2(const double* __restrict data, std::size_t n, double v0, double v1,
                             double v2, double* __restrict memberships) {
  double change = 0.0;
  int on_center = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double a = (data[k] - v0) * (data[k] - v0);
    const double b = (data[k] - v1) * (data[k] - v1);
    const double c = (data[k] - v2) * (data[k] - v2);
    double smallest = a < b ? a : b;
    smallest = c < smallest ? c : smallest;
    const double ra = smallest / a, rb = smallest / b, rc = smallest / c;
    const double sum = (ra + rb) + rc;
    const bool usable = sum == sum;  // false (0/0) for a point on a center
    const double ua = ra / sum, ub = rb / sum, uc = rc / sum;
    double* row = memberships + kFcmClusters * k;
    const double da = std::abs(ua - row[0]), db = std::abs(ub - row[1]), dc = std::abs(uc - row[2]);
    double d = da > db ? da : db;
    d = dc > d ? dc : d;
    d = usable ? d : 0.0;
    change = d > change ? d : change;
    on_center += usable ? 0 : 1;
    row[0] = usable ? ua : row[0];
    row[1] = usable ? ub : row[1];
    row[2] = usable ? uc : row[2];
  }
  if (on_center == 0) return change;
  // The points on a center, by the exact rule (their rows still hold the old memberships).
  const ClusterVector centers(v0, v1, v2);
  for (std::size_t k = 0; k < n; ++k) {
    const double a = (data[k] - v0) * (data[k] - v0);
    const double b = (data[k] - v1) * (data[k] - v1);
    const double c = (data[k] - v2) * (data[k] - v2);
    if (a != 0.0 && b != 0.0 && c != 0.0) continue;
    double* row = memberships + kFcmClusters * k;
    double updated[kFcmClusters];
    memberships_into(data[k], centers, 2.0, updated);
    for (int i = 0; i < kFcmClusters; ++i) {
      change = std::max(change, std::abs(updated[i] - row[i]));
      row[i] = updated[i];
    }
  }
  return change;
}

// Eq. (8)–(10) from the current memberships until max |ΔU| ≤ tolerance.
FcmResult iterate(std::span<const double> data, const ClusterVector& centers,
                  const ClusterVector& lower, const ClusterVector& upper,
                  const FuzzyCMeansSettings& settings, std::span<double> memberships) {
  const std::size_t n = data.size();
  const double m = settings.fuzzifier;
  FcmResult result;
  result.centers = centers;
  for (int iteration = 1; iteration <= settings.max_iterations; ++iteration) {
    // Eq. (8): v_i = Σ u_ik^m x_k / Σ u_ik^m, clamped to the bounds.
    ClusterVector numerator = ClusterVector::Zero(), denominator = ClusterVector::Zero();
    for (std::size_t k = 0; k < n; ++k) {
      for (int i = 0; i < kFcmClusters; ++i) {
        const double w =
            weight_power(memberships[kFcmClusters * k + static_cast<std::size_t>(i)], m);
        numerator(i) += w * data[k];
        denominator(i) += w;
      }
    }
    for (int i = 0; i < kFcmClusters; ++i) {
      if (denominator(i) > 0.0) result.centers(i) = numerator(i) / denominator(i);
    }
    result.centers = clamp(result.centers, lower, upper);
    // Eq. (9)–(10): new memberships and max |ΔU|.
    double change = 0.0;
    if (m == 2.0) {
      change = update_memberships_m2(data.data(), n, result.centers(0), result.centers(1),
                                     result.centers(2), memberships.data());
    }
    if (m != 2.0) {
      change = 0.0;
      for (std::size_t k = 0; k < n; ++k) {
        double* row = &memberships[kFcmClusters * k];
        double updated[kFcmClusters];
        memberships_into(data[k], result.centers, m, updated);
        for (int i = 0; i < kFcmClusters; ++i) {
          change = std::max(change, std::abs(updated[i] - row[i]));
          row[i] = updated[i];
        }
      }
    }
    result.iterations = iteration;
    result.change = change;
    if (change <= settings.tolerance) {
      result.converged = true;
      break;
    }
  }
  return result;
}

void require_storage(std::size_t data, std::span<double> memberships) {
  if (memberships.size() < kFcmClusters * data) {
    throw std::invalid_argument("fuzzy_c_means: membership storage smaller than 3 × data");
  }
}

}  // namespace

FcmResult fuzzy_c_means(std::span<const double> data, const ClusterVector& centers,
                        const ClusterVector& lower, const ClusterVector& upper,
                        const FuzzyCMeansSettings& settings, std::span<double> memberships) {
  require_storage(data.size(), memberships);
  const ClusterVector start = clamp(centers, lower, upper);
  for (std::size_t k = 0; k < data.size(); ++k) {
    memberships_into(data[k], start, settings.fuzzifier, &memberships[kFcmClusters * k]);
  }
  return iterate(data, start, lower, upper, settings, memberships);
}

FcmResult fuzzy_c_means_from_memberships(std::span<const double> data,
                                         std::span<double> memberships,
                                         const FuzzyCMeansSettings& settings) {
  require_storage(data.size(), memberships);
  settings.validate();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  return iterate(data, ClusterVector::Zero(), ClusterVector::Constant(-kInf),
                 ClusterVector::Constant(kInf), settings, memberships);
}

double fcm_objective(std::span<const double> data, const ClusterVector& centers,
                     std::span<const double> memberships, double fuzzifier) {
  double objective = 0.0;
  for (std::size_t k = 0; k < data.size(); ++k) {
    for (int i = 0; i < kFcmClusters; ++i) {
      const double d = data[k] - centers(i);
      objective +=
          weight_power(memberships[kFcmClusters * k + static_cast<std::size_t>(i)], fuzzifier) * d *
          d;
    }
  }
  return objective;
}

SlidingFuzzyCMeans::SlidingFuzzyCMeans(int window, const FuzzyCMeansSettings& settings,
                                       const ClusterVector& lower, const ClusterVector& upper)
    : window_(window), settings_(settings), lower_(lower), upper_(upper) {
  if (window < 3 || window > kMaxWindow) {
    throw InvalidParameter("window", "must be in [3, " + std::to_string(kMaxWindow) + "]");
  }
  settings.validate();
  for (int i = 0; i < kFcmClusters; ++i) {
    if (std::isnan(lower(i)) || std::isnan(upper(i)) || lower(i) > upper(i)) {
      throw InvalidParameter("bounds", "cluster " + std::to_string(i) + " needs lower ≤ upper");
    }
  }
}

ClusterVector SlidingFuzzyCMeans::propose(double x) {
  // The window after this point: the newest min(size, window − 1) committed points, then x.
  const int kept = std::min(size_, window_ - 1);
  const int skip = size_ - kept;
  for (int i = 0; i < kept; ++i)
    work_[static_cast<std::size_t>(i)] =
        ring_[static_cast<std::size_t>((head_ + skip + i) % window_)];
  work_[static_cast<std::size_t>(kept)] = x;
  const int n = kept + 1;
  pending_x_ = x;
  pending_ = true;
  pending_iterations_ = 0;
  if (n < kFcmClusters) {
    pending_clustered_ = false;
    pending_centers_ = centers_;
    return ClusterVector(0.0, 1.0, 0.0);
  }

  ClusterVector start = centers_;
  if (!has_centers_) {
    double lowest = work_[0], highest = work_[0], sum = 0.0;
    for (int k = 0; k < n; ++k) {
      const double value = work_[static_cast<std::size_t>(k)];
      lowest = std::min(lowest, value);
      highest = std::max(highest, value);
      sum += value;
    }
    start = ClusterVector(lowest, sum / n, highest);
  }
  const std::span<const double> data(work_.data(), static_cast<std::size_t>(n));
  const FcmResult result = fuzzy_c_means(
      data, start, lower_, upper_, settings_,
      std::span<double>(memberships_.data(), static_cast<std::size_t>(kFcmClusters * n)));
  pending_iterations_ = result.iterations;
  pending_clustered_ = true;

  // Order free centers ascending (deceleration, noise, acceleration); bounded centers keep the
  // roles their bounds give them.
  std::array<int, kFcmClusters> order = {0, 1, 2};
  const bool free = (lower_.array() == -std::numeric_limits<double>::infinity()).all() &&
                    (upper_.array() == std::numeric_limits<double>::infinity()).all();
  if (free) {
    std::sort(order.begin(), order.end(),
              [&](int a, int b) { return result.centers(a) < result.centers(b); });
  }
  ClusterVector u;
  const double* last =
      &memberships_[static_cast<std::size_t>(kFcmClusters) * static_cast<std::size_t>(n - 1)];
  for (int i = 0; i < kFcmClusters; ++i) {
    pending_centers_(i) = result.centers(order[static_cast<std::size_t>(i)]);
    u(i) = last[order[static_cast<std::size_t>(i)]];
  }
  return u;
}

void SlidingFuzzyCMeans::commit() {
  if (!pending_) return;
  if (size_ < window_) {
    ring_[static_cast<std::size_t>((head_ + size_) % window_)] = pending_x_;
    ++size_;
  } else {
    ring_[static_cast<std::size_t>(head_)] = pending_x_;
    head_ = (head_ + 1) % window_;
  }
  if (pending_clustered_) {
    centers_ = pending_centers_;
    has_centers_ = true;
  }
  pending_ = false;
}

void SlidingFuzzyCMeans::reset() {
  head_ = 0;
  size_ = 0;
  has_centers_ = false;
  centers_.setZero();
  pending_ = false;
}

}  // namespace imm
