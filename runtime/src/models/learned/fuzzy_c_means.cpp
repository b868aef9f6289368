// SPDX-License-Identifier: Apache-2.0
#include "imm/models/learned/fuzzy_c_means.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <utility>

#include "imm/core/invalid_parameter.hpp"
#include "imm/math/lane_math.hpp"

// The membership loop takes AVX-512 or AVX2 where the CPU has it (IMM_VECTOR_CLONES,
// lane_math.hpp).

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

// Ratios below this take libm's cube root: the first guess is read from the ratio as a float.
constexpr double kSmallestGuessedRatio = 1e-37;

// ∛r for r in [kSmallestGuessedRatio, 1) without libm's cbrt (whose frexp and scalbn were most of
// an FCM-IMM step): a first guess from the bits of r as a float (a third of its exponent, FreeBSD
// cbrtf's constant, ~6 % off), then three Halley steps y ← y (y³ + 2r) / (2y³ + r), each cubing
// the relative error (6e-2 → 2e-4 → 1e-11 → rounding). Plain IEEE arithmetic without branches,
// so that the loops over points vectorize and every instruction set gives the same bits.
inline double guessed_cube_root(double r) {
  const auto bits = std::bit_cast<std::uint32_t>(static_cast<float>(r));
  double y = static_cast<double>(std::bit_cast<float>(bits / 3U + 709958130U));
  for (int i = 0; i < 3; ++i) {
    const double y3 = y * y * y;
    y = y * (y3 + 2.0 * r) / (2.0 * y3 + r);
  }
  return y;
}

// ∛r for r in (0, 1]: exactly 1 for the nearest center's own ratio (one root in three per point),
// libm's cbrt below the guess's range.
double cube_root_of_ratio(double r) {
  if (r == 1.0) return 1.0;
  if (r < kSmallestGuessedRatio) return std::cbrt(r);
  return guessed_cube_root(r);
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

// Points per block of the membership updates: their per-point changes are reduced after each
// block (a floating-point max reduction inside the loop stops the vectorizer).
constexpr std::size_t kUpdateBlock = 64;

// Lanes of the reductions over points: the largest change's running maxima and a data set's
// partial sums (SumOrder::kInLanes), point k in lane k mod kLanes. A divisor of kUpdateBlock.
constexpr std::size_t kLanes = 8;
static_assert(kUpdateBlock % kLanes == 0, "a block's changes pad to whole lanes within it");

// New memberships of points [first, first + count) for centers v, the old ones replaced where the
// new ones are usable; writes each point's max |ΔU| (0 where unusable) to `change` and returns the
// number of unusable points. m = 2: w_i = d²_min / d²_i; m = 4: ∛ of it (a ratio of 1 selects 1
// exactly). The operations of memberships_into, without branches, so that the loop vectorizes
// (AVX-512 or AVX2 where the CPU has it). Unusable: a point on a center (0/0), and for m = 4 a
// ratio below the cube root's guess (kSmallestGuessedRatio); memberships_into redoes them.
template <int M>
IMM_VECTOR_CLONES int update_block(const double* __restrict data, std::size_t count, double v0,
                                   double v1, double v2, double* __restrict memberships,
                                   double* __restrict change) {
  int unusable = 0;
  for (std::size_t k = 0; k < count; ++k) {
    const double a = (data[k] - v0) * (data[k] - v0);
    const double b = (data[k] - v1) * (data[k] - v1);
    const double c = (data[k] - v2) * (data[k] - v2);
    double smallest = a < b ? a : b;
    smallest = c < smallest ? c : smallest;
    const double ra = smallest / a, rb = smallest / b, rc = smallest / c;
    double wa = ra, wb = rb, wc = rc;
    bool usable = false;
    if constexpr (M == 4) {
      usable = (ra >= kSmallestGuessedRatio) & (rb >= kSmallestGuessedRatio) &
               (rc >= kSmallestGuessedRatio);
      wa = pick(ra == 1.0, 1.0, guessed_cube_root(pick(usable, ra, 1.0)));
      wb = pick(rb == 1.0, 1.0, guessed_cube_root(pick(usable, rb, 1.0)));
      wc = pick(rc == 1.0, 1.0, guessed_cube_root(pick(usable, rc, 1.0)));
    }
    const double sum = (wa + wb) + wc;
    if constexpr (M == 2) usable = sum == sum;  // false (0/0) for a point on a center
    const double ua = wa / sum, ub = wb / sum, uc = wc / sum;
    double* row = memberships + kFcmClusters * k;
    const double da = std::abs(ua - row[0]), db = std::abs(ub - row[1]), dc = std::abs(uc - row[2]);
    double d = da > db ? da : db;
    d = dc > d ? dc : d;
    change[k] = pick(usable, d, 0.0);
    unusable += usable ? 0 : 1;
    row[0] = pick(usable, ua, row[0]);
    row[1] = pick(usable, ub, row[1]);
    row[2] = pick(usable, uc, row[2]);
  }
  return unusable;
}

// Every point's memberships for centers v with the integer fuzzifier M (2 or 4), by blocks;
// returns max |ΔU|. The unusable points are redone by memberships_into (their rows still hold the
// old memberships).
template <int M>
double update_memberships(const double* data, std::size_t n, const ClusterVector& v,
                          double* memberships) {
  // The largest change in kLanes running maxima (a maximum does not depend on the order it is
  // taken in; one chain of scalar maxima cost a sixth of a data set's iteration).
  double lane_change[kLanes] = {};
  int unusable = 0;
  double block_change[kUpdateBlock];
  for (std::size_t first = 0; first < n; first += kUpdateBlock) {
    const std::size_t count = std::min(kUpdateBlock, n - first);
    unusable += update_block<M>(data + first, count, v(0), v(1), v(2),
                                memberships + kFcmClusters * first, block_change);
    // A short last block's changes padded with zeros (no change is below zero).
    const std::size_t padded = (count + kLanes - 1) / kLanes * kLanes;
    std::fill(block_change + count, block_change + padded, 0.0);
    for (std::size_t k = 0; k < padded; k += kLanes) {
      for (std::size_t l = 0; l < kLanes; ++l) {
        lane_change[l] = std::max(lane_change[l], block_change[k + l]);
      }
    }
  }
  double change = 0.0;
  for (const double lane : lane_change) change = std::max(change, lane);
  if (unusable == 0) return change;
  for (std::size_t k = 0; k < n; ++k) {
    const double a = (data[k] - v(0)) * (data[k] - v(0));
    const double b = (data[k] - v(1)) * (data[k] - v(1));
    const double c = (data[k] - v(2)) * (data[k] - v(2));
    const double smallest = std::min({a, b, c});
    const bool usable =
        M == 2 ? (a != 0.0 && b != 0.0 && c != 0.0)
               : (smallest / a >= kSmallestGuessedRatio && smallest / b >= kSmallestGuessedRatio &&
                  smallest / c >= kSmallestGuessedRatio);
    if (usable) continue;
    double* row = memberships + kFcmClusters * k;
    double updated[kFcmClusters];
    memberships_into(data[k], v, static_cast<double>(M), updated);
    for (int i = 0; i < kFcmClusters; ++i) {
      change = std::max(change, std::abs(updated[i] - row[i]));
      row[i] = updated[i];
    }
  }
  return change;
}

// How eq. (8)'s sums over the points are added: in point order (a window's; the FCM-IMM's
// numbers depend on it to the bit), or point k into partial sum k mod kLanes, the partial sums
// added pairwise at the end (a data set's: one vector of sums, not six chains of dependent
// additions, and a rounding error that grows with n/8 instead of n).
enum class SumOrder { kPointOrder, kInLanes };

// The kLanes partial sums added pairwise: ((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7)).
inline double pairwise_total(double (&sums)[kLanes]) {
  for (std::size_t width = kLanes / 2; width > 0; width /= 2) {
    for (std::size_t l = 0; l < width; ++l) sums[l] = sums[2 * l] + sums[2 * l + 1];
  }
  return sums[0];
}

// Σ_k u_ik^m x_k and Σ_k u_ik^m by SumOrder::kInLanes, u^m for the fuzzifier M (weight_power's
// products; 0: any m, by pow). The partial sums are local, so that they stay in registers.
template <int M>
IMM_VECTOR_CLONES void center_sums_in_lanes(const double* __restrict data, std::size_t n,
                                            const double* __restrict memberships, double m,
                                            double* numerator, double* denominator) {
  double num[kFcmClusters][kLanes] = {}, den[kFcmClusters][kLanes] = {};
  const auto add = [&](std::size_t k, std::size_t l) {
    for (int i = 0; i < kFcmClusters; ++i) {
      const double u = memberships[kFcmClusters * k + static_cast<std::size_t>(i)];
      const double w = M == 0 ? weight_power(u, m) : weight_power(u, static_cast<double>(M));
      num[i][l] += w * data[k];
      den[i][l] += w;
    }
  };
  std::size_t first = 0;
  for (; first + kLanes <= n; first += kLanes) {
    for (std::size_t l = 0; l < kLanes; ++l) add(first + l, l);
  }
  for (std::size_t l = 0; first + l < n; ++l) add(first + l, l);
  for (int i = 0; i < kFcmClusters; ++i) {
    numerator[i] = pairwise_total(num[i]);
    denominator[i] = pairwise_total(den[i]);
  }
}

// Eq. (8)'s sums for every cluster, in the given order.
void center_sums(std::span<const double> data, std::span<const double> memberships, double m,
                 SumOrder order, ClusterVector& numerator, ClusterVector& denominator) {
  if (order == SumOrder::kInLanes) {
    const auto sums = m == 2.0   ? center_sums_in_lanes<2>
                      : m == 3.0 ? center_sums_in_lanes<3>
                      : m == 4.0 ? center_sums_in_lanes<4>
                                 : center_sums_in_lanes<0>;
    sums(data.data(), data.size(), memberships.data(), m, numerator.data(), denominator.data());
    return;
  }
  numerator.setZero();
  denominator.setZero();
  for (std::size_t k = 0; k < data.size(); ++k) {
    for (int i = 0; i < kFcmClusters; ++i) {
      const double w = weight_power(memberships[kFcmClusters * k + static_cast<std::size_t>(i)], m);
      numerator(i) += w * data[k];
      denominator(i) += w;
    }
  }
}

// Eq. (8)–(10) from the current memberships until max |ΔU| ≤ tolerance.
FcmResult iterate(std::span<const double> data, const ClusterVector& centers,
                  const ClusterVector& lower, const ClusterVector& upper,
                  const FuzzyCMeansSettings& settings, std::span<double> memberships,
                  SumOrder order) {
  const std::size_t n = data.size();
  const double m = settings.fuzzifier;
  FcmResult result;
  result.centers = centers;
  for (int iteration = 1; iteration <= settings.max_iterations; ++iteration) {
    // Eq. (8): v_i = Σ u_ik^m x_k / Σ u_ik^m, clamped to the bounds.
    ClusterVector numerator, denominator;
    center_sums(data, memberships, m, order, numerator, denominator);
    for (int i = 0; i < kFcmClusters; ++i) {
      if (denominator(i) > 0.0) result.centers(i) = numerator(i) / denominator(i);
    }
    result.centers = clamp(result.centers, lower, upper);
    // Eq. (9)–(10): new memberships and max |ΔU|.
    double change = 0.0;
    if (m == 2.0) {
      change = update_memberships<2>(data.data(), n, result.centers, memberships.data());
    } else if (m == 4.0) {
      change = update_memberships<4>(data.data(), n, result.centers, memberships.data());
    } else {
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
  if (settings.fuzzifier == 2.0 || settings.fuzzifier == 4.0) {
    // The same memberships as memberships_into's, by the vectorized update over cleared rows.
    std::fill_n(memberships.begin(), kFcmClusters * data.size(), 0.0);
    if (settings.fuzzifier == 2.0) {
      (void)update_memberships<2>(data.data(), data.size(), start, memberships.data());
    } else {
      (void)update_memberships<4>(data.data(), data.size(), start, memberships.data());
    }
  } else {
    for (std::size_t k = 0; k < data.size(); ++k) {
      memberships_into(data[k], start, settings.fuzzifier, &memberships[kFcmClusters * k]);
    }
  }
  return iterate(data, start, lower, upper, settings, memberships, SumOrder::kPointOrder);
}

FcmResult fuzzy_c_means_from_memberships(std::span<const double> data,
                                         std::span<double> memberships,
                                         const FuzzyCMeansSettings& settings) {
  require_storage(data.size(), memberships);
  settings.validate();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  return iterate(data, ClusterVector::Zero(), ClusterVector::Constant(-kInf),
                 ClusterVector::Constant(kInf), settings, memberships, SumOrder::kInLanes);
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

namespace {

// cluster_window's body, inlined into SlidingFuzzyCMeans::propose as well (as a call it cost an
// FCM-IMM step ~5 %).
[[gnu::always_inline]] inline ClusterVector cluster(
    std::span<const double> window, const ClusterVector* previous, const ClusterVector& lower,
    const ClusterVector& upper, const FuzzyCMeansSettings& settings, std::span<double> memberships,
    ClusterVector& centers, int& iterations) {
  const auto n = static_cast<int>(window.size());
  ClusterVector start;
  if (previous != nullptr) {
    start = *previous;
  } else {
    double lowest = window[0], highest = window[0], sum = 0.0;
    for (int k = 0; k < n; ++k) {
      const double value = window[static_cast<std::size_t>(k)];
      lowest = std::min(lowest, value);
      highest = std::max(highest, value);
      sum += value;
    }
    start = ClusterVector(lowest, sum / n, highest);
  }
  const FcmResult result = fuzzy_c_means(window, start, lower, upper, settings, memberships);
  iterations = result.iterations;

  // Order free centers ascending (deceleration, noise, acceleration); bounded centers keep the
  // roles their bounds give them.
  std::array<int, kFcmClusters> order = {0, 1, 2};
  const bool free = (lower.array() == -std::numeric_limits<double>::infinity()).all() &&
                    (upper.array() == std::numeric_limits<double>::infinity()).all();
  if (free) {
    std::sort(order.begin(), order.end(),
              [&](int a, int b) { return result.centers(a) < result.centers(b); });
  }
  ClusterVector u;
  const double* last =
      &memberships[static_cast<std::size_t>(kFcmClusters) * static_cast<std::size_t>(n - 1)];
  for (int i = 0; i < kFcmClusters; ++i) {
    centers(i) = result.centers(order[static_cast<std::size_t>(i)]);
    u(i) = last[order[static_cast<std::size_t>(i)]];
  }
  return u;
}

}  // namespace

ClusterVector cluster_window(std::span<const double> window, const ClusterVector* previous,
                             const ClusterVector& lower, const ClusterVector& upper,
                             const FuzzyCMeansSettings& settings, std::span<double> memberships,
                             ClusterVector& centers, int& iterations) {
  return cluster(window, previous, lower, upper, settings, memberships, centers, iterations);
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
  pending_clustered_ = true;
  return cluster(std::span<const double>(work_.data(), static_cast<std::size_t>(n)),
                 has_centers_ ? &centers_ : nullptr, lower_, upper_, settings_,
                 std::span<double>(memberships_.data(), static_cast<std::size_t>(kFcmClusters * n)),
                 pending_centers_, pending_iterations_);
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
