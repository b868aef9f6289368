// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The lane storage of the banks whose tracks are two axis IMMs (x at an even lane, y after it)
/// stepped by the banks' IMM cycle (runtime/src/tracking/imm_cycle.hpp) — GaFuzzyTrackBank and
/// FcmImmTrackBank: the IMM's Π and log Π as the cycle reads them, the initial log μ, where a
/// mode's entries, log μ and μ̃ sit in a lane, a track's start and its mode probabilities, once
/// for both banks. A mode's entries, the slots after the modes and the kernels are each bank's.

#include <Eigen/Core>
#include <cstddef>
#include <string_view>
#include <vector>

#include "imm/estimation/gaussian_state.hpp"
#include "imm/math/linear_algebra.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/lane_storage.hpp"

namespace imm {

/// Lanes of the modes of two axis IMMs per track (see the file comment).
class IMM_RUNTIME_EXPORT AxisImmLaneStorage : public LaneStorage {
 public:
  /// Modes per axis.
  [[nodiscard]] int mode_count() const { return modes_; }

  /// μ of the x axis's modes, then the y axis's (TwoAxisFilter::mode_probabilities). Throws
  /// std::out_of_range for a track ≥ capacity().
  [[nodiscard]] ModeVector mode_probabilities(std::size_t track) const;

 protected:
  /// The IMM's mode switching: Π (n × n, every entry > 0, checked by the bank) and μ(0).
  struct Switching {
    Eigen::MatrixXd transition;  ///< Π, p_ij at (i, j)
    Eigen::VectorXd initial;     ///< μ(0)
  };
  /// Bank `name` of an IMM switching by `switching`, whose modes hold `entries` slots each (then
  /// log μ and μ̃).
  AxisImmLaneStorage(std::string_view name, const Switching& switching, int entries);

  /// Room for `capacity` tracks in blocks of `block` lanes: the modes' slots, then `extra` slots
  /// of the bank's own. Throws InvalidParameter("capacity") for a capacity outside [1, 2^26].
  void allocate_modes(std::size_t capacity, int block, std::size_t extra);

  /// Slot `entry` of mode j (imm_mode_slot: its entries, then log μ and μ̃).
  [[nodiscard]] int mode_slot(int j, int entry) const { return imm_mode_slot(j, entries_, entry); }
  /// The first slot after the modes'.
  [[nodiscard]] int slots_after_modes() const { return mode_slot(modes_, 0); }

  /// Starts track `track`'s two lanes (ImmEstimator::initialize of each axis): every mode's first
  /// five entries take the axis's [x0, x1, p00, p01, p11] of `state`, its other entries 0, log μ
  /// and μ̃ = μ / max μ their initial values. Returns the track's index; the bank then sets its
  /// own slots and marks the track initialized. Throws std::out_of_range for a track ≥
  /// capacity(), InvalidParameter("initial_state" / "initial_covariance") for a start the
  /// one-track filter refuses (require_initial_state).
  std::ptrdiff_t start_modes(std::size_t track, const GaussianState<4>& state);

  /// Π at i · modes + j, as the cycle reads it.
  [[nodiscard]] const double* transition() const { return transition_.data(); }
  /// log Π likewise.
  [[nodiscard]] const double* log_transition() const { return log_transition_.data(); }
  /// The initial μ (exp of the stored log μ(0)).
  [[nodiscard]] ModeVector initial_probabilities() const;

 private:
  int modes_ = 0;
  int entries_ = 0;
  std::vector<double> transition_;      // π_ij at i * modes + j
  std::vector<double> log_transition_;  // log π_ij likewise
  std::vector<double> initial_log_mu_;  // log μ_j(0)
};

}  // namespace imm
