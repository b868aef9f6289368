// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file
/// Outcome of one filter step. A step that does not return kOk has left the filter untouched
/// (the second of the three error tiers: numerical trouble is a value, not an exception).

#include <string_view>

namespace imm {

/// The outcome of a filter step: kOk, or why the filter was left unchanged.
enum class StepStatus {
  kOk,
  kInvalidMeasurement,    ///< the measurement holds NaN, ±Inf or a value beyond ±1e9
  kSingularInnovation,    ///< S = H P Hᵀ + R is not positive definite
  kUndefinedMeasurement,  ///< h(x) or its Jacobian is undefined at the prediction (range 0)
  kNonFiniteResult,       ///< the update would produce NaN or ±Inf
  kProbabilityUnderflow,  ///< every mode's likelihood is zero even in log space
};

/// A human-readable description of a status.
[[nodiscard]] constexpr std::string_view to_string(StepStatus status) {
  switch (status) {
    case StepStatus::kOk:
      return "ok";
    case StepStatus::kInvalidMeasurement:
      return "invalid measurement (NaN, Inf or |z| > 1e9)";
    case StepStatus::kSingularInnovation:
      return "innovation covariance not positive definite";
    case StepStatus::kUndefinedMeasurement:
      return "measurement function undefined at the prediction";
    case StepStatus::kNonFiniteResult:
      return "update produced a non-finite estimate";
    case StepStatus::kProbabilityUnderflow:
      return "every mode likelihood is zero";
  }
  return "unknown";
}

}  // namespace imm
