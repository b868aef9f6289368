// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// The coordinated-turn IMM mode: an extended Kalman filter whose prediction runs the CT model
/// (imm/models/motion/coordinated_turn.hpp) — the mean through the exact turn, the covariance
/// through its Jacobian, F P Fᵀ + Q — and whose update is the Joseph-form (or iterated) update of
/// any measurement model, as every mode's. Its state [x, vx, y, vy, ω] sits in the IMM's mixing
/// space through a StateEmbedding, beside CV and CA modes. It is the mode of
/// scheduled_noise_mode.hpp with the turn's motion (TurnMotionStep), without a noise schedule
/// (std::nullopt) or, learned, with one.

#include "imm/estimation/scheduled_noise_mode.hpp"

namespace imm {

/// A coordinated-turn EKF mode of an NX-state mixing space, with any measurement model:
/// CoordinatedTurnMode<NX, M>(name, TurnMotionStep{T, coordinated_turn_noise(T, …)}, schedule,
/// measurement, embedding, iterations).
template <int NX, class MeasurementModel>
using CoordinatedTurnMode = ScheduledNoiseMode<NX, TurnMotionStep, MeasurementModel>;

}  // namespace imm
