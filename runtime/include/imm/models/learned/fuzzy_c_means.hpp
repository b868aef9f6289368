// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Fuzzy c-means clustering of scalar data (Bezdek; seed 003 eq. 7–10), c = 3 clusters ordered
/// deceleration / noise / acceleration, as a batch function and as an online clustering of a
/// sliding window.
///
/// With centers v_i and the fuzzifier m > 1, a point x belongs to cluster i with
///   u_i(x) = 1 / Σ_j (d_i / d_j)^{2/(m−1)},  d_i = |x − v_i|               (eq. 7, 9)
/// — the seed prints the exponent as 2/m − 1 and, in eq. (9), the distances with superscripts r;
/// both are read as Bezdek's standard form. A point lying on a center (d_i = 0) belongs to that
/// center alone (to each of several coinciding centers equally). The centers are the
/// u^m-weighted means of the data (eq. 8); iterations stop when max |ΔU| ≤ tolerance (eq. 10)
/// or after max_iterations.
///
/// Bounded centers: cluster i may be confined to [lower_i, upper_i]. The FCM objective
/// Σ_k u_ik^m (x_k − v_i)² is a convex quadratic in v_i, so clamping the weighted mean to the
/// bounds is the exact constrained center update and the alternating optimization still descends.
/// Pinning the noise cluster at 0 (lower = upper = 0) and keeping the outer clusters at least κ
/// away from it is how the FCM-IMM makes the memberships scale-aware (fcm_imm.hpp).
///
/// Memberships depend only on distance ratios: multiplying the data and the free centers by a
/// constant changes nothing. Everything here is allocation-free.

#include <array>
#include <limits>
#include <span>

#include "imm/math/linear_algebra.hpp"
#include "imm/runtime_export.hpp"

namespace imm {

/// The number of clusters: deceleration, noise, acceleration.
inline constexpr int kFcmClusters = 3;
/// Cluster-indexed values: [deceleration, noise, acceleration].
using ClusterVector = Vector<kFcmClusters>;

/// Fuzzy c-means settings.
struct IMM_RUNTIME_EXPORT FuzzyCMeansSettings {
  double fuzzifier = 2.0;    ///< m > 1
  double tolerance = 1e-4;   ///< on max |ΔU|, > 0
  int max_iterations = 100;  ///< ≥ 1

  /// Throws InvalidParameter naming the field.
  void validate() const;
};

/// u(x) for centers v (eq. 9). Sums to 1.
[[nodiscard]] IMM_RUNTIME_EXPORT ClusterVector fcm_memberships(double x,
                                                               const ClusterVector& centers,
                                                               double fuzzifier);

/// The result of a clustering.
struct IMM_RUNTIME_EXPORT FcmResult {
  /// The cluster centers v.
  ClusterVector centers = ClusterVector::Zero();
  /// Iterations done.
  int iterations = 0;
  double change = 0.0;  ///< max |ΔU| of the last iteration
  /// Whether max |ΔU| fell below the tolerance.
  bool converged = false;
};

/// Clusters `data` from `centers`, each confined to [lower_i, upper_i]. `memberships` is
/// caller-provided storage of 3·n values (row k: the memberships of data[k]) and holds the final
/// memberships. Centers are returned as iterated (free centers are not sorted).
IMM_RUNTIME_EXPORT FcmResult fuzzy_c_means(std::span<const double> data,
                                           const ClusterVector& centers, const ClusterVector& lower,
                                           const ClusterVector& upper,
                                           const FuzzyCMeansSettings& settings,
                                           std::span<double> memberships);

/// Clusters `data` from given memberships (row k: the memberships of data[k]) with free centers:
/// the first step computes the centers from them (eq. 8). `memberships` holds the final ones.
/// Eq. (8)'s sums over a data set are taken in eight partial sums (point k into sum k mod 8, added
/// pairwise at the end): vector additions instead of chains of dependent ones, and a rounding
/// error that grows with n/8. fuzzy_c_means (a window's clustering) adds in point order.
IMM_RUNTIME_EXPORT FcmResult fuzzy_c_means_from_memberships(std::span<const double> data,
                                                            std::span<double> memberships,
                                                            const FuzzyCMeansSettings& settings);

/// The FCM objective J = Σ_k Σ_i u_ik^m (x_k − v_i)².
[[nodiscard]] IMM_RUNTIME_EXPORT double fcm_objective(std::span<const double> data,
                                                      const ClusterVector& centers,
                                                      std::span<const double> memberships,
                                                      double fuzzifier);

/// One clustering of a sliding window on caller storage — what SlidingFuzzyCMeans::propose does
/// once its window holds three points: `window` holds the n ≥ 3 points (the new one last),
/// `previous` the last centers (null before the first clustering: then the window's minimum, mean
/// and maximum), and `memberships` room for 3·n values. Returns the new point's memberships;
/// `centers` receives the new centers (free ones sorted: deceleration, noise, acceleration),
/// `iterations` the iterations done.
IMM_RUNTIME_EXPORT ClusterVector cluster_window(
    std::span<const double> window, const ClusterVector* previous, const ClusterVector& lower,
    const ClusterVector& upper, const FuzzyCMeansSettings& settings, std::span<double> memberships,
    ClusterVector& centers, int& iterations);

/// Online FCM over a sliding window of the most recent points, warm-started from the previous
/// centers. Follows the IMM's propose/commit contract: propose(x) clusters the committed window
/// with x appended (the oldest point dropping out of a full window) and returns x's memberships
/// without changing anything; commit() makes that window and its centers current.
///
/// Until the window holds three points the clusters are undefined and x is labelled noise,
/// u = [0, 1, 0]. Free centers start at the window's minimum, mean and maximum, bounded ones at
/// their bounds nearest to those; after every clustering they are sorted so that index 0 is the
/// most negative (deceleration) and index 2 the most positive (acceleration).
class IMM_RUNTIME_EXPORT SlidingFuzzyCMeans {
 public:
  /// The longest window.
  static constexpr int kMaxWindow = 128;

  SlidingFuzzyCMeans() = default;
  /// Throws InvalidParameter for a window outside [3, kMaxWindow], bad settings or bounds.
  SlidingFuzzyCMeans(int window, const FuzzyCMeansSettings& settings, const ClusterVector& lower,
                     const ClusterVector& upper);

  /// The memberships of x in the committed window with x appended; changes nothing.
  [[nodiscard]] ClusterVector propose(double x);
  /// Makes the last propose()'s window and centers current.
  void commit();
  /// Empties the window.
  void reset();

  /// The window length.
  [[nodiscard]] int window() const { return window_; }
  /// The number of points in the window.
  [[nodiscard]] int size() const { return size_; }
  /// The committed centers (sorted: deceleration, noise, acceleration).
  [[nodiscard]] const ClusterVector& centers() const { return centers_; }
  /// Iterations of the last propose() (0 when it did not cluster).
  [[nodiscard]] int last_iterations() const { return pending_iterations_; }

 private:
  int window_ = 16;
  FuzzyCMeansSettings settings_;
  ClusterVector lower_ = ClusterVector::Constant(-std::numeric_limits<double>::infinity());
  ClusterVector upper_ = ClusterVector::Constant(std::numeric_limits<double>::infinity());

  std::array<double, kMaxWindow> ring_{};  // committed points, oldest at head_
  int head_ = 0, size_ = 0;
  ClusterVector centers_ = ClusterVector::Zero();
  bool has_centers_ = false;

  std::array<double, kMaxWindow> work_{};  // the proposed window, contiguous
  std::array<double, static_cast<std::size_t>(kFcmClusters) * kMaxWindow> memberships_{};
  double pending_x_ = 0.0;
  ClusterVector pending_centers_ = ClusterVector::Zero();
  bool pending_clustered_ = false;
  bool pending_ = false;
  int pending_iterations_ = 0;
};

}  // namespace imm
