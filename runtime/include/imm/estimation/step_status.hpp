// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Outcome of one filter step. A step that does not return kOk has left the filter untouched
/// (the second of the three error tiers: numerical trouble is a value, not an exception).

#include <array>
#include <string_view>

#include "imm/core/enum_names.hpp"

namespace imm {

/// The outcome of a filter step: kOk, or why the filter was left unchanged.
enum class StepStatus {
  kOk,
  kInvalidMeasurement,    ///< the measurement holds NaN, ±Inf or a value beyond ±1e9
  kSingularInnovation,    ///< S = H P Hᵀ + R is not positive definite
  kUndefinedMeasurement,  ///< h(x) or its Jacobian is undefined at the prediction (range 0)
  kNonFiniteResult,       ///< the update would produce NaN, ±Inf or a negative variance
  kProbabilityUnderflow,  ///< every mode's likelihood is zero even in log space
  /// The interval since the last cycle is not one the model predicts over: not positive, or, for
  /// a model built for one sample period (a learned one), not within kIntervalTolerance of a whole
  /// number of periods (TrackFilter::step_over).
  kUnsupportedInterval,
};

/// Each status with its description (core/enum_names.hpp).
inline constexpr std::array kStepStatusNames{
    EnumName<StepStatus>{StepStatus::kOk, "ok"},
    EnumName<StepStatus>{StepStatus::kInvalidMeasurement,
                         "invalid measurement (NaN, Inf or |z| > 1e9)"},
    EnumName<StepStatus>{StepStatus::kSingularInnovation,
                         "innovation covariance not positive definite"},
    EnumName<StepStatus>{StepStatus::kUndefinedMeasurement,
                         "measurement function undefined at the prediction"},
    EnumName<StepStatus>{StepStatus::kNonFiniteResult, "update produced a non-finite estimate"},
    EnumName<StepStatus>{StepStatus::kProbabilityUnderflow, "every mode likelihood is zero"},
    EnumName<StepStatus>{StepStatus::kUnsupportedInterval,
                         "interval not positive or not a whole number of the model's sample "
                         "periods"}};

/// A human-readable description of a status.
[[nodiscard]] constexpr std::string_view to_string(StepStatus status) {
  return name_of(kStepStatusNames, status);
}

}  // namespace imm
