// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Many independent tracks of one GA-fuzzy IMM (ga_fuzzy_imm.hpp), stepped by one call: the
/// multi-track form of make_ga_fuzzy_imm_filter, as TrackBank is of the plain IMM.
///
/// Layout: every track is two axis filters (x, then y), and every axis filter is a lane. Lanes
/// are stored structure of arrays and stepped 16 or 8 at a time (eight or four tracks) through
/// the banks' IMM cycle (imm_cycle.hpp) with the fuzzy-noise step (fuzzy_noise_step.hpp, the
/// arithmetic the trainer's GA fitness runs too), on packs of lanes with no branches and no calls:
/// AVX-512, AVX2 or the baseline, chosen at run time (lane_isa.hpp), without fused multiply-add,
/// so a track's result does not depend on the instruction set, on its position or on the number
/// of tracks.
///
/// Numerics are those of ImmEstimator: log-space mode probabilities (log μ stored, μ̃ = μ / max μ
/// kept from the last posterior for the prediction), likelihoods N(r; 0, S) in log space. The
/// differences to the one-track filter are rounding only: exp and log are lane_exp and lane_log
/// (lane_math.hpp, within 2 ulp of libm's), and divisions by c_j and S are multiplications by
/// their inverses. A track whose plot is unusable, or whose x or y step fails, is left exactly as
/// it was, both axes, with the status of the first axis that failed (the one-track TwoAxisFilter
/// advances x when only y fails, which cannot happen for finite estimates with R > 0).
///
/// Every transition probability must be positive (eq. 20 with transition_stay < 1, or one
/// level): c_j then never vanishes, so no mode is ever unreachable. Nothing is allocated after
/// construction.

#include <Eigen/Core>
#include <cstddef>
#include <span>
#include <vector>

#include "imm/estimation/gaussian_state.hpp"
#include "imm/estimation/step_status.hpp"
#include "imm/filters/fuzzy_noise_step.hpp"
#include "imm/filters/ga_fuzzy_imm.hpp"
#include "imm/math/lane_isa.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/axis_imm_lane_storage.hpp"

namespace imm {

/// N tracks of one GA-fuzzy IMM with Cartesian plots, stepped together (see the file comment).
class IMM_RUNTIME_EXPORT GaFuzzyTrackBank : public AxisImmLaneStorage {
 public:
  /// Axis lanes per block of the layout: stepped as one block (two AVX-512 packs: two independent
  /// chains) where the AVX-512 kernels run (lane_isa.hpp), as two blocks of 8 otherwise (packs
  /// of 4 under AVX2, of 2 on the baseline).
  static constexpr int kBlock = 16;

  /// Room for `capacity` tracks of the IMM of `spec`. Throws InvalidParameter naming the field
  /// for an invalid spec, a transition probability of zero ("settings.transition_stay") or a
  /// capacity outside [1, 2^26]. `wide_blocks` steps blocks of 16 lanes at once (the default
  /// where the AVX-512 clone runs) or of 8; the results do not depend on it.
  GaFuzzyTrackBank(const GaFuzzyImmSpec& spec, std::size_t capacity,
                   bool wide_blocks = wide_vector_clones());

  /// Starts (or restarts) track `track` from [x, vx, y, vy] (the covariance's two axis blocks;
  /// the cross terms are not used, as by the one-track filter): every mode takes the state, the
  /// mode probabilities their initial values, the tables' previous input 0. Throws
  /// std::out_of_range for a track ≥ capacity(), InvalidParameter("initial_state" /
  /// "initial_covariance") for a start the one-track filter refuses (require_initial_state).
  void initialize(std::size_t track, const GaussianState<4>& state);

  /// The combined estimate [x, vx, y, vy] (block-diagonal covariance: the axes are independent).
  [[nodiscard]] GaussianState<4> estimate(std::size_t track) const;

  // mode_count() (the levels) and mode_probabilities() are AxisImmLaneStorage's; step(), step()
  // with the NIS and candidate_log_likelihoods() TrackBankCalls'.

 private:
  // One IMM cycle of the tracks; with `nis`, per axis the modes' ν_j and S_j of the update
  // collapsed with the predicted c_j, then νᵀ S⁻¹ ν: the one-track filter's last_step_nis to
  // 1e-12 relative (the bank's state is the filter's to rounding).
  void step_lanes(const LaneStep& call) override;
  // Each axis's log Σ_j c_j N_j of a trial step of every mode (the modes' noise is read from the
  // plot), gated by the squared distance to the prediction without a plot (the modes' mean q,
  // collapsed): the one-track filter's candidate_log_likelihood and candidate_distance after
  // predict(), to 1e-12 relative (its exponentials are libm's).
  void score_lanes(const LaneScore& call) override;
  bool wide_blocks_ = false;
  lanes::FuzzyAxisConstants axis_;
  std::vector<lanes::FuzzyLevelConstants> levels_;
  std::vector<double> scratch_;      // one block's plots, step flags and codes
  std::vector<double> innovations_;  // a step's modes' innovations where it states its NIS
};

}  // namespace imm
