// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Labels for the input estimator where the tracks have no truth (a recorded regime without truth
/// for training): the acceleration a fixed-interval smoother finds in the plots.
///
/// The smoother: the constant-q CV IMM per axis tuned on the training split by its predictive
/// likelihood (tune_imm_baseline on a plots-only set), run forward over every window, then a
/// Rauch–Tung–Striebel pass backward over its moment-matched estimates — x(k|k), P(k|k) and the
/// prediction F x(k|k), F P(k|k) Fᵀ + Q̄(k) with Q̄(k) = Σ_j c_j(k+1) q_j G Gᵀ, the process noise
/// the predicted mode probabilities expect. The label of scan k is the smoothed velocity's forward
/// difference (v(k+1|N) − v(k|N))/T, the acceleration over the transition from k (what the truth's
/// commanded acceleration is); positions and velocities are the smoothed ones. A model trained on
/// such labels records it (`training.labels_rts_smoother` = 1).

#include "imm/datasets/track.hpp"
#include "imm/filters/axis_cv_imm.hpp"

namespace imm::trainer::mlp {

/// `tracks` with its truth replaced by the smoother's (x, vx, ax, y, vy, ay; has_truth true), each
/// axis smoothed by `imm`. Throws std::runtime_error for a window with a gap or a failed step.
[[nodiscard]] datasets::TrackSet smoothed_truth(const datasets::TrackSet& tracks,
                                                const AxisCvImmSpec& imm);

}  // namespace imm::trainer::mlp
