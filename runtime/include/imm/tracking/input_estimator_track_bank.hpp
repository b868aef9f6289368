// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Many independent tracks of one neural input-estimation model (mlp_input_estimator.hpp),
/// stepped by one call: the multi-track form of make_mlp_input_estimator_filter, as TrackBank is
/// of the plain IMM.
///
/// Layout: every track is two axis filters (x, then y), every axis filter a lane; lanes are
/// stored structure of arrays and stepped 16 or 8 at a time in loops over lanes with no branches
/// and no calls (cv_axis_lanes.hpp for both Kalman filters, the network layer by layer), which the
/// compiler vectorizes: AVX-512 or AVX2 where the CPU has it, chosen at run time, without fused
/// multiply-add, so a track's result does not depend on the instruction set, on its position or
/// on the number of tracks. The ten-innovation windows are shift registers and rings whose
/// position is per lane, selected by masks.
///
/// Each lane runs the scan MlpInputEstimatorFilter runs for one axis (one source), so a track's
/// estimates equal the one-track filter's to the bit. A track whose plot is unusable, or whose x
/// or y step fails, is left exactly as it was, both axes, with the status of the first axis that
/// failed (the one-track TwoAxisFilter advances x when only y fails, which cannot happen for
/// finite estimates with R > 0). Nothing is allocated after construction.
#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <span>
#include <vector>

#include "imm/estimation/gaussian_state.hpp"
#include "imm/estimation/step_status.hpp"
#include "imm/filters/mlp_input_estimator.hpp"
#include "imm/math/lane_isa.hpp"
#include "imm/math/lane_math.hpp"
#include "imm/runtime_export.hpp"
#include "imm/tracking/lane_storage.hpp"

namespace imm {

/// N tracks of one input-estimation model with Cartesian plots, stepped together (see the file
/// comment).
class IMM_RUNTIME_EXPORT InputEstimatorTrackBank : public LaneStorage {
 public:
  /// Axis lanes per block of the layout: stepped as one block (two AVX-512 vectors) where the
  /// AVX-512 clone runs, as two blocks of 8 otherwise.
  static constexpr int kBlock = 16;

  /// Room for `capacity` tracks of `model`. Throws InvalidParameter naming the field as
  /// MlpInputEstimatorFilter does (settings, a network that does not take two inputs,
  /// input_variance), or for a capacity outside [1, 2^26]. `wide_blocks` steps blocks of 16 lanes
  /// at once (the default where the AVX-512 clone runs) or of 8; the results do not depend on it.
  InputEstimatorTrackBank(const MlpInputEstimatorModel& model, std::size_t capacity,
                          bool wide_blocks = wide_vector_clones());

  /// Starts (or restarts) track `track` from [x, vx, y, vy] (the covariance's two axis blocks):
  /// both Kalman filters of each axis take the state, the input estimate 0, the windows their
  /// start (MlpInputEstimatorFilter::initialize). Throws std::out_of_range for a track ≥
  /// capacity(), InvalidParameter("initial_state" / "initial_covariance") for a start the
  /// one-track filter refuses (require_initial_state).
  void initialize(std::size_t track, const GaussianState<4>& state);

  /// The corrected estimate [x, vx, y, vy] (block-diagonal covariance: the axes are independent).
  [[nodiscard]] GaussianState<4> estimate(std::size_t track) const;

  /// The input estimates (û_x, û_y) of the last scan.
  [[nodiscard]] Eigen::Vector2d acceleration(std::size_t track) const;

  /// [1, 1]: one mode per axis (as TwoAxisFilter::mode_probabilities of the one-track filter).
  [[nodiscard]] ModeVector mode_probabilities(std::size_t track) const;

  // step(), step() with the NIS and candidate_log_likelihoods() are TrackBankCalls'.

 private:
  struct Constants;
  // One scan of the tracks; with `nis`, ν_x²/S_x + ν_y²/S_y of the primary KFs' update (the
  // one-track filter's last_step_nis, to the bit).
  void step_lanes(const LaneStep& call) override;
  // The sum of the axes' log N(ν; 0, S) under the primary KF's prediction with the last input
  // estimate, gated by Σ ν²/S: the one-track filter's candidate_log_likelihood and
  // candidate_distance after predict(), to the bit.
  void score_lanes(const LaneScore& call) override;
  bool wide_blocks_ = false;
  std::shared_ptr<const Constants> constants_;  // the scan's, made from the model once
  std::vector<double> scratch_;  // one block's plots, flags, codes and two layers' activations
};

}  // namespace imm
